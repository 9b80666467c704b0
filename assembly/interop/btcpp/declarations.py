"""What a BT.CPP file declares besides its trees: fvtree's metadata comment (what the XML cannot
hold: cell settings, design, the subtrees' typed params) and the ports Groot2 declares for each
tree in `<TreeNodesModel><SubTree ID=...>`, typed by what they feed when they say no type."""

from __future__ import annotations

import json

from assembly.errors import TreeError, TreeErrors
from assembly.interop.btcpp.nodes_model import PORT_TYPES
from assembly.interop.btcpp.values import PORT_REF, PortError, from_port, to_port
from assembly.interop.btcpp.writer import META_TAG
from behaviours.skill_kit.registry import SKILLS
from fvfiles.xml_source import XmlNode


def metadata(root: XmlNode, file: str) -> dict:
    """The `<!-- fvtree {json} -->` comment the exporter writes (or the `<?fvtree {json}?>` of
    files exported before it, which BT.CPP cannot load); empty for files from elsewhere."""
    found = [(text.strip()[len(META_TAG):], line) for text, line in root.comments
             if text.strip().startswith(META_TAG + " {")]
    found += [(data, root.line) for target, data in root.instructions if target == META_TAG]
    for data, line in found[:1]:
        try:
            meta = json.loads(data)
        except json.JSONDecodeError as exc:
            raise TreeErrors([TreeError(f"the fvtree metadata is not JSON: {exc.msg}", file, line)]) from None
        if not isinstance(meta, dict):
            raise TreeErrors([TreeError("the fvtree metadata must be a JSON object", file, line)])
        return meta
    return {}


OUR_TYPES = {bt: ours for ours, bt in PORT_TYPES.items()}


def _port_types(x: XmlNode, out: dict[str, str], int_ports: set[tuple[str, str]]) -> dict[str, str]:
    """The type of each `{port}` of a subtree body, from the skill param or decorator field it feeds."""
    for attr, text in x.attrs.items():
        ref = PORT_REF.match(text)
        if ref and x.tag in SKILLS and attr in SKILLS[x.tag].PARAMS:
            out.setdefault(ref.group(1), SKILLS[x.tag].PARAMS[attr].type)
        elif ref and (x.tag, attr) in int_ports:
            out.setdefault(ref.group(1), "int")
    for child in x.children:
        _port_types(child, out, int_ports)
    return out


def groot_subtree_params(model: XmlNode | None, trees: dict[str, XmlNode], file: str,
                         int_ports: set[tuple[str, str]]) -> dict[str, dict]:
    """Subtree ports Groot2 declares in `<TreeNodesModel><SubTree ID=...>`, typed by their `type`
    or, when they have none, by what each feeds in the subtree's body (a string when it feeds
    nothing typed; `int_ports` are the (tag, attribute) pairs of BT.CPP nodes that take an int)."""
    out: dict[str, dict] = {}
    for node in model.children if model is not None else []:
        if node.tag != "SubTree" or node.attrs.get("ID") not in trees:
            continue
        types = _port_types(trees[node.attrs["ID"]], {}, int_ports)
        params = out[node.attrs["ID"]] = {}
        for port in (p for p in node.children if p.tag == "input_port" and "name" in p.attrs):
            declared = OUR_TYPES.get(port.attrs.get("type", ""))
            decl = params[port.attrs["name"]] = {"type": declared or types.get(port.attrs["name"], "str")}
            if "default" in port.attrs:
                try:
                    decl["default"] = from_port(port.attrs["default"], decl["type"])
                except PortError as exc:
                    raise TreeErrors([TreeError(f"default: {exc}", file, port.line, f"<SubTree ID={node.attrs['ID']!r}>")])
    return out


def default_ports(params: dict[str, dict]) -> dict[str, str]:
    """The port spelling of each declared param default (those that have one)."""
    out = {}
    for name, decl in params.items():
        try:
            out[name] = to_port(decl["default"]) if "default" in decl else None
        except PortError:
            out[name] = None
    return {k: v for k, v in out.items() if v is not None}
