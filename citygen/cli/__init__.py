"""The ``citygen`` command: a thin layer over the library's public functions, one module per
command group.

Every error a user can cause is a :class:`~citygen.errors.CitygenError`; it is
printed as one line per problem on stderr and the command exits with code 2.

- :mod:`.validate`: ``validate``, ``schema``
- :mod:`.export`: ``render``, ``export``
- :mod:`.generate`: ``generate``, ``dataset`` (``verify``, ``lock``), ``rebuild``
- :mod:`.assets`: ``assets list``, ``assets render``
- :mod:`.runner`: ``bench``, ``run`` (the MuJoCo runner)
- :mod:`.train`: ``train`` (the optional ``train`` extra)

:mod:`.app` puts them on one typer app; ``citygen.cli:main`` is the console script.
"""

from citygen.cli.app import app, main

__all__ = ["app", "main"]
