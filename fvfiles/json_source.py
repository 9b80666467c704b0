"""Reading JSON that keeps its lines: every object of the document a `Located` mapping with the
line it starts on and the line of each key, so that a check of its values can point at them;
duplicate keys, malformed text and deep nesting are refused with the line."""

from __future__ import annotations

import json
import json.scanner
from pathlib import Path
from typing import Any

from fvfiles.yaml_source import Located, SourceError, read_text


def load_json(path: str | Path) -> Any:
    """The JSON document at `path` with every object a `Located` (the line it starts on and the
    line of each key); a located SourceError for malformed JSON, duplicate keys or deep nesting."""
    text = read_text(path)
    decoder = json.JSONDecoder()
    # The pure-Python decoder's hooks used here (JSONObject, scan_once, parse_object, py_make_scanner) are
    # real but undocumented, and typeshed leaves them out: hence the ignores below.

    def parse_object(s_and_end: tuple[str, int], *args: Any) -> tuple[Located, int]:
        s, start = s_and_end
        pairs, end = json.decoder.JSONObject(  # type: ignore[attr-defined]
            s_and_end, decoder.strict, decoder.scan_once, None, list, memo)  # type: ignore[attr-defined]
        out = Located()
        out.file, out.line, out.key_lines = str(path), s.count("\n", 0, start) + 1, {}
        cursor = start
        for key, value in pairs:  # in order: each key is found after the one before
            at = s.find(json.dumps(key), cursor, end)
            cursor = max(cursor, at + 1)
            line = s.count("\n", 0, at) + 1 if at >= 0 else out.line
            if key in out:
                raise SourceError(f"duplicate key {key!r}", str(path), line)
            out[key], out.key_lines[key] = value, line
        return out, end

    memo: dict = {}
    decoder.parse_object = parse_object  # type: ignore[attr-defined]
    decoder.scan_once = json.scanner.py_make_scanner(decoder)  # type: ignore[attr-defined]  # it calls parse_object
    try:
        return decoder.decode(text)
    except json.JSONDecodeError as exc:
        raise SourceError(f"malformed JSON: {exc.msg}", str(path), exc.lineno) from None
    except RecursionError:
        raise SourceError("malformed JSON: nested too deeply", str(path)) from None
