"""The real BehaviorTree.CPP v4 for the tests: the library inside the `behaviortreepy` wheel (PyPI),
driven through a small C++ file of stub nodes (tests/data/btcpp/stub_nodes.cpp), which models
fvtree's own kinds (ForEachElement, StatusMap, FvParallel) as fvtree runs them.

behaviortreepy's Python API registers nodes without ports (`register_simple_action(name, fn)`), and
BT.CPP refuses any port attribute its registered node does not declare, so it alone cannot load a
tree whose skills have params. Its wheel exports the whole BT.CPP API, though: stub_nodes.cpp is
compiled against the BT.CPP headers of the same behaviortreepy release (its sdist, from PyPI) and
linked to the wheel's library, then loaded here with ctypes. It registers each node of a file's
`<TreeNodesModel>` with its typed ports and defaults, ticks the tree, and writes BT.CPP's XSD
(`writeTreeXSD`) for those models. `LibraryUnavailable` says why it cannot be built here.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

SOURCE = Path(__file__).parent / "data" / "btcpp" / "stub_nodes.cpp"
SCRIPT_KEY = re.compile(r"@([A-Za-z_]\w*)\s*(?:==|!=|<=|>=|<|>)\s*(\S+)")
TIMEOUT = 600  # download and compile: generous, two cores shared with other work


class LibraryUnavailable(Exception):
    """behaviortreepy, its sdist's headers or a C++ compiler is missing (the message says which)."""


@dataclass
class Run:
    """One load-and-tick of a tree: BT.CPP's final status and tick count, and what every stub
    read from its ports (path, node ID, {port: value as text}), in tick order."""

    status: str
    ticks: int
    reads: list[tuple[str, str, dict[str, str]]]
    elements: list[tuple[str, str]]  # (ForEachElement path, element id), each time it starts one


class Library:
    """The compiled stub nodes, loaded into this process."""

    def __init__(self, path: Path):
        self._lib = ctypes.CDLL(str(path))
        for name, args in (("fv_btcpp_run", [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int]),
                           ("fv_btcpp_fulltree", [ctypes.c_char_p, ctypes.c_char_p]),
                           ("fv_btcpp_xsd", [ctypes.c_char_p]), ("fv_btcpp_version", [])):
            getattr(self._lib, name).argtypes = args
            getattr(self._lib, name).restype = ctypes.c_char_p

    def version(self) -> str:
        """BT.CPP's own version string (e.g. 4.8.2)."""
        return self._lib.fv_btcpp_version().decode()

    def run(self, xml: str, failing: Iterable[str] = (), max_ticks: int = 1000, elements: Iterable[str] = ()) -> Run:
        """Load `xml` with stubs for its `<TreeNodesModel>` (those named in `failing` fail, the
        others succeed; a ForEachElement without `elements` runs over `elements`, the design's) and
        tick it until it stops running; RuntimeError with BT.CPP's message if it refuses the file
        or a port."""
        text = (spec(xml, blackboard=True) + "".join(f"F\t{name}\n" for name in failing)
                + "".join(f"E\t{element}\n" for element in elements))
        out = self._lib.fv_btcpp_run(text.encode(), xml.encode(), max_ticks).decode()
        if out.startswith("ERROR\t"):
            raise RuntimeError(out[6:])
        head, *lines = out.splitlines()
        _, status, ticks = head.split("\t")
        reads, started = [], []
        for line in lines:
            kind, path, node_id, *ports = line.split("\t")
            if kind == "ELEMENT":
                started.append((path, node_id))
            else:
                reads.append((path, node_id, dict(p.split("=", 1) for p in ports)))
        return Run(status, int(ticks), reads, started)

    def fulltree(self, xml: str) -> str:
        """What BT.CPP's Groot2 publisher sends for `xml` loaded with stubs (`WriteTreeToXML` with
        `_uid`, `_fullpath` and the models): the reference for `fvtree run --groot2`'s tree."""
        out = self._lib.fv_btcpp_fulltree(spec(xml, blackboard=True).encode(), xml.encode()).decode()
        if out.startswith("ERROR\t"):
            raise RuntimeError(out[6:])
        return out

    def xsd(self, xml: str) -> str:
        """BT.CPP's writeTreeXSD for a factory with the nodes of `xml`'s `<TreeNodesModel>`."""
        out = self._lib.fv_btcpp_xsd(spec(xml, blackboard=False).encode()).decode()
        if out.startswith("ERROR\t"):
            raise RuntimeError(out[6:])
        return out


def spec(xml: str, blackboard: bool) -> str:
    """The stub spec of a file: each `<TreeNodesModel>` node with its ports, and (with
    `blackboard`) a neutral value for each root-blackboard key its scripts read (0.0, false or
    the empty string, by the value it is compared with)."""
    root = ET.fromstring(xml)
    lines = []
    for node in root.find("TreeNodesModel") or []:
        if node.tag == "SubTree":
            continue
        lines.append(f"N\t{node.tag}\t{node.get('ID')}")
        for port in node.findall("input_port"):
            default = port.get("default")
            lines.append(f"P\t{port.get('name')}\t{port.get('type', 'std::string')}\t"
                         f"{'0' if default is None else '1'}\t{default or ''}")
    if blackboard:
        keys: dict[str, tuple[str, str]] = {}
        for element in root.iter():
            for text in (element.get("code"), element.get("_while")):
                for key, value in SCRIPT_KEY.findall(text or ""):
                    kind = ("bool", "false") if value in ("true", "false") else ("string", "") \
                        if not re.match(r"^-?[\d.]", value) else ("double", "0")
                    keys.setdefault(key, kind)
        lines += [f"B\t{key}\t{kind}\t{value}" for key, (kind, value) in keys.items()]
    return "\n".join(lines) + "\n"


def _sdist_headers(version: str, cache: Path) -> Path:
    """The BT.CPP include directory of the behaviortreepy sdist of `version` (downloaded once)."""
    include = cache / f"behaviortreepy-{version}" / "include"
    if include.is_dir():
        return include
    with tempfile.TemporaryDirectory(dir=cache) as tmp:
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--no-binary",
                               ":all:", "-d", tmp, f"behaviortreepy=={version}"],
                              capture_output=True, text=True, timeout=TIMEOUT, check=False)
        archives = list(Path(tmp).glob("behaviortreepy-*.tar.gz"))
        if done.returncode or not archives:
            raise LibraryUnavailable(f"cannot download the behaviortreepy {version} sdist: {done.stderr.strip()[-300:]}")
        prefix = f"behaviortreepy-{version}/BehaviorTree.CPP/include/"
        with tarfile.open(archives[0]) as tar:
            members = [m for m in tar.getmembers() if m.name.startswith(prefix) and (m.isfile() or m.isdir())]
            for m in members:
                m.name = m.name[len(prefix):]
            tar.extractall(Path(tmp) / "include", members=members, filter="data")
        include.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.replace(Path(tmp) / "include", include)
        except OSError:  # another session put it there first
            if not include.is_dir():
                raise
    return include


def build(cache: Path) -> Library:
    """The stub library for the installed behaviortreepy, compiled into `cache` once per release."""
    try:
        import behaviortreepy
    except ImportError as exc:
        raise LibraryUnavailable(f"behaviortreepy is not installed ({exc}); pip install -e '.[test]'") from None
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None:
        raise LibraryUnavailable("no C++ compiler (g++) to build the stub nodes; apt-get install g++")
    version = importlib.metadata.version("behaviortreepy")
    wheel_lib = next(Path(behaviortreepy.__file__).parent.glob("_behaviortreepy*.so"))
    cache.mkdir(parents=True, exist_ok=True)
    out = cache / f"stub_nodes-{version}-{SOURCE.stat().st_mtime_ns}.so"
    if not out.exists():
        include = _sdist_headers(version, cache)
        tmp = out.with_suffix(f".{os.getpid()}.tmp")
        # The wheel is built for manylinux2014 (the old libstdc++ string ABI): so is the stub file.
        done = subprocess.run([compiler, "-std=c++17", "-O0", "-shared", "-fPIC", "-D_GLIBCXX_USE_CXX11_ABI=0",
                               f"-I{include}", str(SOURCE), "-o", str(tmp), str(wheel_lib),
                               f"-Wl,-rpath,{wheel_lib.parent}"],
                              capture_output=True, text=True, timeout=TIMEOUT, check=False)
        if done.returncode:
            raise LibraryUnavailable(f"the stub nodes do not compile against behaviortreepy {version}:\n"
                                     f"{done.stderr[-2000:]}")
        os.replace(tmp, out)
    return Library(out)
