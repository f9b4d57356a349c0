"""A MkDocs hook for the manual: parts of the env's docstring placed in the task pages.

``RollingDiskEnv``'s class docstring is the environment's manual, and holds each task's observation table. A task
page shows its table where it writes ``<!-- env-manual: Observation Space / circle -->`` (the block of the section
``## Observation Space`` that begins with ``task="circle"`` and ends with its table), or a whole section with
``<!-- env-manual: Episode End -->``. The docstring is read from the source by griffe, as mkdocstrings reads it, so
the pages follow it and nothing is copied by hand; a marker that finds nothing fails the build.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import griffe
from mkdocs.exceptions import PluginError

ENV_CLASS = "rolling_disk_env.envs.rolling_disk.RollingDiskEnv"
"""The class whose docstring is the manual."""
MARKER = re.compile(r"<!-- env-manual: (?P<section>[A-Za-z ]+?)(?: / (?P<task>\w+))? -->")


@functools.cache
def manual() -> str:
    """The env's class docstring, as griffe reads it from the source (not imported) for mkdocstrings."""
    root = Path(__file__).resolve().parents[2]
    module, _, name = ENV_CLASS.rpartition(".")
    extensions = griffe.load_extensions(str(Path(__file__).with_name("sphinx_roles.py")))
    return griffe.load(module, search_paths=[str(root)], extensions=extensions)[name].docstring.value


def section(title: str) -> list[str]:
    """The lines of the docstring's ``## title`` section, without its heading."""
    lines = manual().splitlines()
    try:
        start = lines.index(f"## {title}") + 1
    except ValueError:
        raise PluginError(f"{ENV_CLASS}'s docstring has no section '## {title}'") from None
    end = next((i for i in range(start, len(lines)) if lines[i].startswith("## ")), len(lines))
    return lines[start:end]


def task_block(title: str, task: str) -> list[str]:
    """The block of section ``title`` that begins with ``task="<task>"`` and ends with the table after it."""
    lines = section(title)
    start = next((i for i, line in enumerate(lines) if f'task="{task}"' in line), None)
    if start is None:
        raise PluginError(f"section '## {title}' of {ENV_CLASS}'s docstring says nothing of task={task!r}")
    table = next((i for i in range(start, len(lines)) if lines[i].startswith("|")), None)
    if table is None:
        raise PluginError(f"section '## {title}' of {ENV_CLASS}'s docstring has no table for task={task!r}")
    end = next((i for i in range(table, len(lines)) if not lines[i].startswith("|")), len(lines))
    return lines[start:end]


def replace(match: re.Match) -> str:
    """The docstring's text for one marker."""
    title, task = match["section"], match["task"]
    lines = section(title) if task is None else task_block(title, task)
    return "\n".join(lines).strip("\n")


def on_page_markdown(markdown: str, **kwargs) -> str:
    """MkDocs event: replaces every marker of the page by the docstring's text."""
    return MARKER.sub(replace, markdown)
