"""Seeds: every random draw in citygen comes from a generator made here.

A scene is a function of (generator version, config, seed). Each stage gets its
own :class:`numpy.random.Generator` derived from ``SeedSequence([seed, stage_id])``,
so changing how a later stage draws never changes an earlier stage's output.
Children (one per block, tile or agent) are derived with :func:`child`, never by
sharing one generator across independent items.

>>> a = stage_rng(7, "terrain").integers(1 << 30)
>>> b = stage_rng(7, "terrain").integers(1 << 30)
>>> bool(a == b), bool(a == stage_rng(7, "blocks").integers(1 << 30))
(True, False)
"""

from __future__ import annotations

import hashlib

import numpy as np

#: Stage identifiers. Their numbers are part of the reproducibility contract:
#: never renumber one, only append.
STAGES: dict[str, int] = {
    "blocks": 1,
    "ground": 2,
    "terrain": 3,
    "placement": 4,
    "agents": 5,
    "task": 6,
}

MAX_SEED = 2**64 - 1


def _check_seed(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"a seed must be an integer in [0, 2**64 - 1], got {seed!r}")
    return int(seed)


def stage_seed(seed: int, stage: str) -> np.random.SeedSequence:
    """The seed sequence of one generator stage of the scene with this seed."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage {stage!r}; expected one of {', '.join(STAGES)}")
    return np.random.SeedSequence([_check_seed(seed), STAGES[stage]])


def stage_rng(seed: int, stage: str) -> np.random.Generator:
    """A fresh generator for one stage of the scene with this seed."""
    return np.random.default_rng(stage_seed(seed, stage))


def child(rng: np.random.Generator, key: int) -> np.random.Generator:
    """A generator for item ``key`` (a block, tile, agent ...) derived from ``rng``'s seed.

    Unlike ``rng.spawn``, the result depends only on the parent's seed and ``key``,
    not on how many children were derived before it, so items can be generated
    in any order (or in parallel) with the same result.
    """
    seq = rng.bit_generator.seed_seq
    if not isinstance(seq, np.random.SeedSequence):
        raise TypeError("child() needs a generator created from a numpy SeedSequence")
    return np.random.default_rng(np.random.SeedSequence(seq.entropy, spawn_key=(*seq.spawn_key, int(key))))


def uniform(rng: np.random.Generator, lo_hi) -> float:
    """A uniform draw from a config range ``[low, high]``; ``low`` itself when the range is empty.

    >>> uniform(np.random.default_rng(0), (2.0, 2.0))
    2.0
    """
    lo, hi = lo_hi
    return float(rng.uniform(lo, hi)) if hi > lo else float(lo)


def scene_seed(master_seed: int, split: str, index: int) -> int:
    """The seed of scene ``index`` of a named split, from the split's master seed.

    Stable across processes and machines (no ``hash()``): the split name enters
    through SHA-256.
    """
    name = int.from_bytes(hashlib.sha256(split.encode("utf-8")).digest()[:8], "little")
    seq = np.random.SeedSequence([_check_seed(master_seed), name, int(index)])
    return int(seq.generate_state(2, np.uint32).view(np.uint64)[0])
