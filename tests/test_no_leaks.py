"""Nothing leaks, nothing explodes: an error quotes a key only when it looks like a field name
(never the lines of a file that is no tree: before, `fvtree validate /etc/shadow` printed each
password hash as "unknown top-level field 'root:$6$...'"); `include:` reads only files under the
tree's folder unless allowed, and so does `design:`; a model file's arrays are sized from the zip directory and the .npy
headers before any is inflated (before: a 2 MB file holding 2 GiB of zeros took 2.2 GB of memory
and 14 s here, 4.4 GB and 103 s on a loaded machine); and fvtree starts from an installation its
user cannot write (before: `cannot cache function 'pairwise_sum': no locator available`)."""

from __future__ import annotations

import io
import json
import os
import shutil
import stat
import struct
import subprocess
import sys
import time
import tracemalloc
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from assembly.cli import main
from fvfiles import user_cache
from fvfiles.npz_files import npz_problem
from perception.learning.models import ModelError, load_model

ROOT = Path(__file__).resolve().parents[1]
SECRET = "root:$6$Zm9vYmFyc2FsdA$SECRETHASHVALUE:19000:0:99999:7:::"
SHADOW = f"{SECRET}\ndaemon:*:19000:0:99999:7:::\n"
NODE = "root: {skill: move_to, name: go, params: {offset: [0.01, 0, 0]}}\n"


def fvtree(capsys, *args: str) -> tuple[int, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out + err


# ---- errors quote keys, not files ----------------------------------------------------------

def test_validating_a_file_that_is_no_tree_prints_none_of_its_lines(tmp_path, capsys):
    shadow = tmp_path / "shadow"
    shadow.write_text(SHADOW)
    code, text = fvtree(capsys, "validate", str(shadow))
    assert code == 2
    assert "SECRET" not in text and "$6$" not in text and "daemon" not in text
    assert f"{shadow}:1: unknown top-level field (a key of {len(SECRET) - 1} characters that is no field name" in text
    code, text = fvtree(capsys, "show", str(shadow))
    assert code == 2 and "SECRET" not in text


def test_a_misspelt_field_is_still_quoted_with_its_did_you_mean(tmp_path, capsys):
    tree = tmp_path / "t.yaml"
    tree.write_text("version: 1\nname: t\nrooot: {}\n" + NODE)
    code, text = fvtree(capsys, "validate", str(tree))
    assert code == 2 and "unknown top-level field 'rooot' (did you mean 'root'?)" in text


def test_design_and_cell_files_quote_no_line_either(tmp_path, capsys):
    design = tmp_path / "d.json"
    design.write_text(json.dumps({SECRET: 1, "nodes": [], "edges": []}))
    cell = tmp_path / "c.yaml"
    cell.write_text(f"kind: sim\n{SECRET}\n")
    for args in (["validate", str(design)], ["validate", "--cell", str(cell)]):
        code, text = fvtree(capsys, *args)
        assert code == 2 and "SECRET" not in text and "no field name, not shown" in text, text


# ---- include: only under the tree's folder ------------------------------------------------------

@pytest.fixture
def outside(tmp_path) -> Path:
    """A folder beside the tree's, with a secret file and a subtree file in it."""
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    (folder / "shadow").write_text(SHADOW)
    (folder / "lift.yaml").write_text("version: 1\nsubtrees:\n  lift:\n    root: {skill: move_to, name: up, "
                                      "params: {offset: [0, 0, 0.01]}}\n")
    return folder


def tree_including(tmp_path: Path, *includes: str) -> Path:
    (tmp_path / "tree").mkdir(exist_ok=True)
    tree = tmp_path / "tree" / "t.yaml"
    tree.write_text(f"version: 1\nname: t\ninclude: {json.dumps(list(includes))}\n" + NODE)
    return tree


@pytest.mark.parametrize("how", ["absolute", "dotdot", "symlink"])
def test_an_include_outside_the_trees_folder_is_refused_unread(tmp_path, outside, capsys, how):
    link = tmp_path / "tree" / "inside.yaml"
    given = {"absolute": str(outside / "shadow"), "dotdot": "../elsewhere/shadow", "symlink": "inside.yaml"}[how]
    tree = tree_including(tmp_path, given)
    if how == "symlink":
        link.symlink_to(outside / "shadow")
    code, text = fvtree(capsys, "validate", str(tree))
    assert code == 2 and "SECRET" not in text
    assert f"{tree}:3: include {given!r}: outside the tree's folder {tree.parent.resolve()}, so it is not read" in text
    assert "--allow-include DIR" in text


def test_an_include_through_a_symbolic_link_loop_is_a_located_error(tmp_path, capsys):
    """Before: exit 1, 'RuntimeError: Symlink loop from ...' with no file and line."""
    tree = tree_including(tmp_path, "loop.yaml")
    (tree.parent / "loop.yaml").symlink_to(tree.parent / "pool.yaml")
    (tree.parent / "pool.yaml").symlink_to(tree.parent / "loop.yaml")
    code, text = fvtree(capsys, "validate", str(tree))
    assert code == 2 and f"{tree}:3: include 'loop.yaml': cannot be resolved" in text, text


def test_an_allowed_folder_may_be_included_from(tmp_path, outside, capsys, monkeypatch):
    tree = tree_including(tmp_path, str(outside / "lift.yaml"))
    tree.write_text(tree.read_text().replace(NODE, "root: {subtree: lift, name: go}\n"))
    monkeypatch.delenv("FVTREE_INCLUDE_PATH", raising=False)
    assert fvtree(capsys, "validate", str(tree))[0] == 2
    code, text = fvtree(capsys, "--allow-include", str(outside), "validate", str(tree))
    assert code == 0, text
    monkeypatch.setenv("FVTREE_INCLUDE_PATH", str(outside))
    assert fvtree(capsys, "validate", str(tree))[0] == 0
    # allowed or not, a file that is no subtree file is not printed
    assert "SECRET" not in fvtree(capsys, "validate", str(tree_including(tmp_path, str(outside / "shadow"))))[1]


@pytest.mark.parametrize("how", ["absolute", "dotdot", "symlink"])
def test_a_design_outside_the_trees_folder_is_refused_unread_like_an_include(tmp_path, outside, capsys, how,
                                                                             monkeypatch):
    """`design: /etc/shadow` (or a `../` path, or a link leading out) was opened and parsed."""
    monkeypatch.delenv("FVTREE_INCLUDE_PATH", raising=False)  # and restored after --allow-include set it
    shutil.copy(ROOT / "trees" / "design" / "two_bays.json", outside / "design.json")
    (tmp_path / "tree").mkdir()
    link = tmp_path / "tree" / "inside.json"
    given = {"absolute": str(outside / "shadow"), "dotdot": "../elsewhere/shadow", "symlink": "inside.json"}[how]
    if how == "symlink":
        link.symlink_to(outside / "shadow")
    tree = tmp_path / "tree" / "t.yaml"
    tree.write_text(f"version: 1\nname: t\ndesign: {given}\n" + NODE)
    code, text = fvtree(capsys, "validate", str(tree))
    assert code == 2 and "SECRET" not in text
    assert f"{tree}:3: design {given!r}: outside the tree's folder {tree.parent.resolve()}, so it is not read" in text
    tree.write_text(f"version: 1\nname: t\ndesign: {outside / 'design.json'}\n" + NODE)
    assert fvtree(capsys, "validate", str(tree))[0] == 2
    code, text = fvtree(capsys, "--allow-include", str(outside), "validate", str(tree))
    assert code == 0, text


# ---- model files: sized before they are inflated ----------------------------------------------

def zeros_npz(path: Path, n_bytes: int, name: str = "x_fit.npy") -> None:
    """A real .npz whose one member is an .npy of `n_bytes` zeros, deflated about 1000:1, written in
    about a second: one compressed 64 MiB block repeated (deflate blocks after a full flush stand
    alone), in a zip written by hand (zipfile cannot take data compressed already)."""
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "|u1", "fortran_order": False, "shape": (n_bytes,)})
    header, chunk = head.getvalue(), bytes(64 << 20)
    repeats = n_bytes // len(chunk)
    deflate = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = deflate.compress(header) + deflate.flush(zlib.Z_FULL_FLUSH)
    block = deflate.compress(chunk) + deflate.flush(zlib.Z_FULL_FLUSH)
    end = deflate.flush(zlib.Z_FINISH)
    crc = zlib.crc32(header)
    for _ in range(repeats):
        crc = zlib.crc32(chunk, crc)
    size, packed, fname = len(header) + n_bytes, len(first) + len(block) * repeats + len(end), name.encode()
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, 8, 0, 0, crc, packed, size, len(fname), 0) + fname)
        f.write(first)
        for _ in range(repeats):
            f.write(block)
        f.write(end)
        at = f.tell()
        central = struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 8, 0, 0, crc, packed, size,
                              len(fname), 0, 0, 0, 0, 0, 0) + fname
        f.write(central)
        f.write(struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, 1, 1, len(central), at, 0))


@pytest.fixture(scope="module")
def bomb(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bomb") / "force.npz"
    zeros_npz(path, 2 << 30)
    return path


def test_a_2_mb_model_file_holding_2_gib_is_refused_at_once(bomb):
    assert bomb.stat().st_size < 3 << 20
    tracemalloc.start()
    cpu = time.process_time()
    with pytest.raises(ModelError, match="not loaded: its arrays take 2048 MiB uncompressed, at most 64 MiB"):
        load_model(bomb, "force")
    cpu = time.process_time() - cpu
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert cpu < 0.5 and peak < 8 << 20, (cpu, peak)


def npy_promising(shape: tuple[int, ...], holding: int) -> bytes:
    """An .npy header for float64 of `shape`, followed by only `holding` bytes of data."""
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return head.getvalue() + bytes(holding)


@pytest.mark.parametrize(("shape", "message"), [
    ((1 << 37,), "x_fit.npy: an array of 1048576 MiB (137438953472 float64), at most 64 MiB"),
    ((1 << 20,), "x_fit.npy: its header promises 8388608 bytes, the file holds 1152"),
])
def test_a_header_promising_more_than_its_member_holds_is_refused(tmp_path, shape, message):
    """numpy allocates what the header promises before it reads: a small member must not promise much."""
    path = tmp_path / "forged.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("x_fit.npy", npy_promising(shape, 1024))
    assert npz_problem(path, 64 << 20) == message
    with pytest.raises(ModelError, match="not loaded: x_fit.npy: "):
        load_model(path, "force")


def test_an_npz_of_too_many_arrays_is_refused(tmp_path):
    path = tmp_path / "many.npz"
    np.savez(path, **{f"a{i}": np.zeros(1) for i in range(300)})
    assert npz_problem(path, 64 << 20) == "300 arrays, at most 256"


def test_the_shipped_models_still_load():
    for kind in ("force", "stir"):
        assert load_model(ROOT / "trees" / "models" / f"{kind}_sim.npz", kind).kind == kind
        assert npz_problem(ROOT / "trees" / "models" / f"{kind}_sim.npz", 64 << 20) is None


# ---- a read-only installation -------------------------------------------------------------------

PACKAGES = ("assembly", "behaviours", "drivers", "perception", "fvfiles")


@pytest.mark.slow
def test_fvtree_starts_from_an_installation_its_user_cannot_write(tmp_path):
    """The packages copied and made read-only (chmod a-w), with no writable home. Run as root, as
    here, permissions do not stop a write: each `__pycache__` is then made a file, so that numba's
    in-tree cache cannot be made either, which is what numba meets in a read-only installation."""
    install = tmp_path / "install"
    for package in PACKAGES:
        shutil.copytree(ROOT / package, install / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "trees", install / "trees")
    for folder in [install, *(p for p in install.rglob("*") if p.is_dir())]:
        (folder / "__pycache__").touch()
    (tmp_path / "no_home").touch()  # a home under a file: nothing can be made there
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
    env.update(HOME=str(tmp_path / "no_home" / "home"), PYTHONPATH=str(install), PYTHONDONTWRITEBYTECODE="1",
               TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    modes = {p: p.stat().st_mode for p in install.rglob("*")}
    for p in modes:
        p.chmod(p.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    tree = tmp_path / "short.yaml"
    tree.write_text("version: 1\nname: short\n" + NODE)

    def fvtree_there(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "assembly.cli", *args], cwd=install, env=env,
                              capture_output=True, text=True, timeout=600, check=False)

    try:
        validated = fvtree_there("validate", "trees/assembly.yaml")
        ran = fvtree_there("run", str(tree), "--runs-dir", str(tmp_path / "runs"), "--no-record", "--no-plots")
    finally:
        for p, mode in modes.items():
            p.chmod(mode)
    assert validated.returncode == 0, validated.stderr[-2000:]
    assert "trees/assembly.yaml: ok" in validated.stdout
    assert ran.returncode == 0 and ran.stdout.startswith("SUCCESS"), ran.stderr[-2000:]
    cache = tmp_path / "tmp" / f"fvtree-{os.getuid()}" / "numba"
    assert any(cache.rglob("*.nbi")), "numba's kernels are cached in the user's own temp directory"


def test_numba_cache_dir_is_the_users_choice_first(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert user_cache.use_user_cache_for_numba() == str(tmp_path / "mine")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert user_cache.use_user_cache_for_numba() == str(tmp_path / "xdg" / "fvtree" / "numba")
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "xdg" / "fvtree" / "numba")


def test_a_temp_cache_dir_someone_else_made_is_not_used(monkeypatch, tmp_path):
    if os.getuid() != 0:
        pytest.skip("making a directory owned by another user needs root")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    (tmp_path / "file").touch()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file" / "cache"))  # the user cache cannot be made
    monkeypatch.setattr(user_cache.tempfile, "gettempdir", lambda: str(tmp_path))
    planted = tmp_path / f"fvtree-{os.getuid()}" / "numba"
    planted.mkdir(parents=True)
    os.chown(planted.parent, 65534, 65534)  # made by another user ("nobody") before us
    assert user_cache.use_user_cache_for_numba() is None
    os.chown(planted.parent, 0, 0)
    assert user_cache.use_user_cache_for_numba() == str(planted)


def test_a_recording_holding_2_gib_is_refused_before_training(tmp_path, capsys):
    """`fvtree train` reads a recording (.npz) the same way: sized before anything is inflated."""
    data = tmp_path / "data.npz"
    zeros_npz(data, 2 << 30, name="features.npy")
    cpu = time.process_time()
    code, text = fvtree(capsys, "train", "force", str(data), "--out", str(tmp_path / "m.npz"))
    assert code == 2 and f"{data}: not loaded: its arrays take 2048 MiB uncompressed, at most 1024 MiB" in text
    assert time.process_time() - cpu < 2.0  # loading the learning modules included
