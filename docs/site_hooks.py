"""MkDocs hook: the site's home page is the README, and repository files the pages link to
outside ``docs/`` become part of the site.

The pages link as a repository browser reads them: the README to ``docs/training.md``, a page to
``../examples/EDITING.md`` or ``../benchmarks/plots/learning.png``. This hook makes the same
links work in the site: the README becomes ``index.md`` with its links rebased onto ``docs/``,
and each linked file outside ``docs/`` is added under ``repo/`` by its repository path (a
Markdown file as a page, whose own links are followed in turn). A link to a file that does not
exist is left alone, so ``mkdocs build --strict`` still reports it.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files, InclusionLevel

# A Markdown link or image target, or an HTML src/href, up to its anchor.
LINK = re.compile(r"(\]\(|src=\"|href=\")([^)\"\s#]+)")


def _relative(url: str) -> bool:
    return not ("://" in url or url.startswith(("/", "mailto:")))


def rebase(text: str, source_dir: str, target_dir: str) -> str:
    """``text`` with each relative link written from ``source_dir`` rewritten from ``target_dir``
    (both relative to the repository)."""

    def fix(match: re.Match) -> str:
        url = match.group(2)
        if not _relative(url):
            return match.group(0)
        target = posixpath.normpath(posixpath.join(source_dir, url))
        return match.group(1) + posixpath.relpath(target, target_dir or ".")

    return LINK.sub(fix, text)


def _outside_links(src_uri: str, text: str):
    for match in LINK.finditer(text):
        url = match.group(2)
        if _relative(url):
            target = posixpath.normpath(posixpath.join(posixpath.dirname(src_uri), url))
            if target.startswith("../"):
                yield target


def on_files(files: Files, config) -> Files:
    docs = Path(config.docs_dir).resolve()
    repo = docs.parent
    readme = (repo / "README.md").read_text(encoding="utf-8")
    home = File.generated(config, "index.md", content=rebase(readme, ".", docs.name))
    files.append(home)
    queue = [f for f in files if f.src_uri.endswith(".md")]
    while queue:
        page = queue.pop()
        for target in _outside_links(page.src_uri, page.content_string):
            path = (docs / target).resolve()
            if target in files.src_uris or not path.is_file() or not path.is_relative_to(repo):
                continue  # a missing file stays missing: strict mode reports the link
            rel = path.relative_to(repo).as_posix()
            added = File(
                target,
                str(docs),
                config.site_dir,
                config.use_directory_urls,
                dest_uri="repo/" + rel,
                inclusion=InclusionLevel.NOT_IN_NAV,  # reached from the pages that link to it
            )
            if rel.endswith(".md"):
                added.dest_uri = "repo/" + rel[:-3] + ".html"
                queue.append(added)
            files.append(added)
    return files
