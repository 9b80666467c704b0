"""Errors of an imported tree said of the XML file: the importer writes YAML and validates it, and
what validation finds about a node is reported at the line of the XML element it came from, not at
a line of YAML the user never saw."""

from __future__ import annotations

from assembly.errors import TreeError, TreeErrors
from assembly.language.kinds import NODE_KINDS


def node_lines(doc: dict, lines: dict[int, int]) -> dict[str, int]:
    """Node path -> XML line of every node mapping of an imported document (`lines`: id of a
    mapping -> its line): paths from the root for the main tree, from each subtree's root for
    the subtrees' bodies (in the expanded tree they follow the instance's path)."""
    out: dict[str, int] = {}

    def walk(node: object, parent: str) -> None:
        if not isinstance(node, dict):
            return
        kind = next((k for k in node if k in NODE_KINDS), None)
        if kind is None:
            return
        name = node.get("name", node[kind]) if NODE_KINDS[kind].typed else node[kind]
        path = f"{parent}/{name}" if parent else str(name)
        if id(node) in lines:
            out.setdefault(path, lines[id(node)])
        for child in [node["child"]] if "child" in node else node.get("children") or []:
            walk(child, path)

    for sub in (doc.get("subtrees") or {}).values():
        walk(sub.get("root"), "")
    walk(doc.get("root"), "")
    return out


def _line_of(path: str | None, lines: dict[str, int]) -> int | None:
    """The line of the node at `path`: itself, or the longest tail of it that is a subtree body's path."""
    if path is None:
        return None
    parts = path.strip("/").split("/")
    for start in range(len(parts)):
        line = lines.get("/".join(parts[start:]))
        if line is not None:
            return line
    return None


def relocate(errors: TreeErrors, yaml_name: str, xml_file: str, lines: dict[str, int]) -> TreeErrors:
    """`errors` with those said of the generated YAML (`yaml_name`) said of `xml_file` instead, at
    the line of the node each names (the file alone when it names none)."""
    out = []
    for e in errors.errors:
        if isinstance(e, TreeError) and e.file == yaml_name:
            e = TreeError(e.message, xml_file, _line_of(e.path, lines), e.path, e.hint)
        out.append(e)
    return TreeErrors(out)
