"""The values users get wrong, by the kind of argument they are given to: the fuzzer's
vocabulary (``tests/fuzz``). Each value has a *class* (``"nan"``, ``"folder"``, …) and whether
it must be refused (:data:`MUST_REFUSE`) or may be a correct value of some argument (0, a
negative, a huge number, an int for a float)."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, NamedTuple

#: value classes that no argument can take: each must be refused naming the argument
MUST_REFUSE = frozenset(
    {
        "wrong type",
        "nan",
        "inf",
        "-inf",
        "empty string",
        "list for scalar",
        "folder",
        "folder.yaml",
        "missing file",
        "unreadable file",
        "wrong format",
        "not utf-8",
    }
)


class Bad(NamedTuple):
    """One fuzz value: its class and the value (a Python object, or command-line text)."""

    kind: str
    value: Any


class Files(NamedTuple):
    """Paths of the file-like values, made once in a temporary folder."""

    folder: Path
    folder_yaml: Path
    missing: Path
    unreadable: Path
    binary: Path
    wrong_json: Path
    wrong_yaml: Path

    @classmethod
    def make(cls, root: Path) -> Files:
        """Create them under ``root``."""
        (root / "a_folder").mkdir()
        (root / "folder.yaml").mkdir()
        locked = root / "locked.yaml"
        locked.write_text("vehicle: {m1: 1}\n")
        os.chmod(locked, 0)  # readable anyway by root: then a wrong-format file
        binary = root / "picture.yaml"
        binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff\xfe")
        wrong_json = root / "element.json"
        wrong_json.write_text("{not: json, [1, 2")
        wrong_yaml = root / "list.yaml"
        wrong_yaml.write_text("- 1\n- 2\n")
        return cls(
            root / "a_folder",
            root / "folder.yaml",
            root / "missing.yaml",
            locked,
            binary,
            wrong_json,
            wrong_yaml,
        )

    def values(self) -> list[Bad]:
        """The file-like values as :class:`Bad` (paths as strings)."""
        return [
            Bad("folder", str(self.folder)),
            Bad("folder.yaml", str(self.folder_yaml)),
            Bad("missing file", str(self.missing)),
            Bad("unreadable file", str(self.unreadable)),
            Bad("not utf-8", str(self.binary)),
            Bad("wrong format", str(self.wrong_json)),
            Bad("wrong format", str(self.wrong_yaml)),
        ]


def numbers(default: Any) -> list[Bad]:
    """Numbers users get wrong for a real argument (``default``: its declared default)."""
    out = [
        Bad("wrong type", "fast"),
        Bad("nan", math.nan),
        Bad("inf", math.inf),
        Bad("-inf", -math.inf),
        Bad("zero", 0.0),
        Bad("negative", -1.0),
        Bad("huge", 1e300),
        Bad("empty string", ""),
        Bad("list for scalar", [1.0, 2.0]),
        Bad("wrong type", True),
        Bad("wrong type", {"a": 1}),
    ]
    if isinstance(default, float) and default.is_integer() and default != 0:
        out.append(Bad("int for float", int(default)))
    return out


def integers() -> list[Bad]:
    """Values users get wrong for an integer argument."""
    return [
        Bad("wrong type", 1.5),
        Bad("wrong type", "3"),
        Bad("nan", math.nan),
        Bad("inf", math.inf),
        Bad("zero", 0),
        Bad("negative", -1),
        Bad("huge", 10**12),
        Bad("list for scalar", [2]),
        Bad("wrong type", True),
        Bad("float for int", 2.0),
    ]


def generic(files: Files) -> list[Bad]:
    """Values for an argument of free form (a name, a path, an object, a choice)."""
    return [
        Bad("number", 3),
        Bad("nan", math.nan),
        Bad("empty string", ""),
        Bad("list for scalar", ["a", "b"]),
        Bad("wrong type", {"a": 1}),
        Bad("wrong type", "no-such-name"),
        *files.values(),
    ]


def command_line(files: Files) -> list[Bad]:
    """Command-line texts users get wrong for one flag (every flag takes text)."""
    return [
        Bad("wrong type", "fast"),
        Bad("nan", "nan"),
        Bad("inf", "inf"),
        Bad("-inf", "-inf"),
        Bad("zero", "0"),
        Bad("negative", "-1"),
        Bad("huge", "1e300"),
        Bad("empty string", ""),
        Bad("list for scalar", "[1, 2]"),
        Bad("int for float", "2"),
        Bad("float for int", "2.0"),
        *files.values(),
    ]
