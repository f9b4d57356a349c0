"""A griffe extension for the manual: the docstrings' Sphinx roles as links, and their targets' stars kept.

The package's docstrings are Markdown with Google-style sections, with two habits Markdown reads otherwise:

* they name other objects with Sphinx roles (``:func:`simulate```, ``:class:`~rolling_disk_env.envs.RollingDiskEnv```),
  which Markdown would print as they are: each becomes an optional cross-reference of mkdocs-autorefs, a link where
  the site documents the object, code text where it does not (private helpers, the engine's internals), never a
  broken link;
* they write a target with a star, ``dphi*`` or ``theta*``, and two such stars in a paragraph would make the text
  between them emphasis: a star after a name is escaped (outside code, and unless it closes an emphasis).
"""

from __future__ import annotations

import re

import griffe

TARGET_STAR = re.compile(r"(?<=\w)\*(?!\w)")
"""A star right after a name and not before one: ``dphi*``, not ``2*pi`` nor ``**kwargs``."""
KEPT = re.compile(r"(`+).*?\1|(?<![\w*])\*(?=\w)[^*\n]*?(?<=\w)\*(?![\w*])")
"""What keeps its stars: a code span, and emphasis, ``*word*``."""
ROLE = re.compile(r":(?:func|meth|class|data|attr|mod|exc|obj):`(~?)([\w.]+)`")
"""A Sphinx role: ``:kind:`target``` or ``:kind:`~target``` (``~``: show the last name only)."""


def autoref(match: re.Match, scope: griffe.Object) -> str:
    """The role as an optional autoref: a dotted target is absolute, a bare name is looked up from ``scope``."""
    short, target = match.group(1), match.group(2)
    if "." in target and target.split(".")[0] in ("rolling_disk_env", "agents"):
        identifier = target
    else:
        identifier = _resolve(target, scope)
    label = target.rsplit(".", 1)[-1] if short else target
    return f'<autoref identifier="{identifier}" optional><code>{label}</code></autoref>'


def _resolve(name: str, scope: griffe.Object) -> str:
    """The path of ``name`` seen from ``scope``: a member of the object, of its parents, or of its module."""
    head = name.split(".")[0]
    obj: griffe.Object | None = scope
    while obj is not None:
        if head in obj.members:
            return f"{obj.path}.{name}"
        obj = obj.parent
    return name


def escape_target_stars(text: str) -> str:
    """``text`` with the stars of targets escaped, except in code spans, emphasis and fenced code blocks."""
    lines, fenced = [], False
    for line in text.split("\n"):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced:
            parts, last = [], 0
            for span in KEPT.finditer(line):
                parts += [TARGET_STAR.sub(r"\\*", line[last : span.start()]), span.group(0)]
                last = span.end()
            line = "".join([*parts, TARGET_STAR.sub(r"\\*", line[last:])])
        lines.append(line)
    return "\n".join(lines)


def _objects(obj: griffe.Object):
    """``obj`` and every object defined in it (aliases, the names a module imports, are skipped)."""
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _objects(member)


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles of every docstring of a package once griffe has loaded all of it, so that a role
    can name an object defined further down (see the module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:
        for obj in _objects(pkg):
            if obj.docstring is not None:
                text = escape_target_stars(obj.docstring.value)
                obj.docstring.value = ROLE.sub(lambda match, obj=obj: autoref(match, obj), text)
