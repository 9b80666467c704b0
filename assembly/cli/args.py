"""The argparse value types of `fvtree` (seeds, positive numbers, existing files, ELEMENT=placed|planned)
and the options several commands share, so each is checked and worded the same everywhere."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

Subparsers = argparse._SubParsersAction  # what `add_subparsers()` returns; each group module adds its commands to it


def _number(convert: Callable[[str], float], minimum: float, strict: bool) -> Callable[[str], float]:
    """argparse type: a finite number of at least `minimum` (above it when `strict`)."""

    def parse(text: str) -> float:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {convert.__name__}, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
        if value < minimum or (strict and value == minimum):
            raise argparse.ArgumentTypeError(f"must be {'>' if strict else '>='} {minimum}, got {text}")
        return value

    return parse


SEED = _number(int, 0, strict=False)
POSITIVE_INT = _number(int, 1, strict=False)
POSITIVE = _number(float, 0, strict=True)
NON_NEGATIVE = _number(float, 0, strict=False)


def existing_file(text: str) -> str:
    """argparse type: a path to a file that exists."""
    if not Path(text).is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return text


def element_mark(text: str) -> tuple[str, str]:
    """argparse type: ELEMENT=placed|planned."""
    element, _, status = text.partition("=")
    if not element or status not in ("placed", "planned"):
        raise argparse.ArgumentTypeError(f"expected ELEMENT=placed or ELEMENT=planned, got {text!r}")
    return element, status


def add_cell_option(command: argparse.ArgumentParser) -> None:
    """--cell of the commands that run a tree: the cell to run it on."""
    command.add_argument("--cell", default="sim", help="cell file or packaged cell name (default: sim)")


def add_perception_option(command: argparse.ArgumentParser) -> None:
    """--perception of the commands that run a tree: how the simulated FingerVision perceives."""
    command.add_argument("--perception", choices=("signals", "pixels"), default=None,
                         help="simulated FingerVision: from contact signals, or rendered frames through the pipeline")
