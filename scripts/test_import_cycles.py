"""Checks of scripts/import-cycles.py (run: `python3 scripts/test_import_cycles.py`
or pytest)."""
import contextlib
import importlib.util
import io
import os
import tempfile
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "import_cycles", os.path.join(os.path.dirname(os.path.abspath(__file__)), "import-cycles.py"))
import_cycles = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(import_cycles)


def crate(files):
    """A workspace with one crate `demo` holding `files` (path -> source)."""
    root = Path(tempfile.mkdtemp())
    for path, text in files.items():
        p = root / "crates" / "demo" / "src" / path
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return root


def run(fn, root):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = fn(root)
    return rc, out.getvalue()


def test_a_circle_around_three_files_is_found():
    root = crate({
        "lib.rs": "pub mod a;\npub mod b;\npub mod c;\npub use a::A;\n",
        "a.rs": "use crate::b::B;\npub struct A(B);\n",
        "b.rs": "pub struct B;\nfn f() { let _ = crate::c::C; }\n",
        "c.rs": "use super::{a::{self, A}};\npub struct C;\nfn g(_: A) {}\n",
    })
    rc, out = run(import_cycles.circles, root)
    assert rc == 1, out
    assert "circle of 3 files" in out, out
    assert "a.rs -> b.rs" in out and "b.rs -> c.rs" in out and "c.rs -> a.rs" in out, out


def test_a_re_export_comments_strings_and_tests_make_no_circle():
    root = crate({
        "lib.rs": "pub mod a;\npub mod b;\npub use a::A;\n",
        # b re-exports a's type without using it; a uses b's.
        "a.rs": "use crate::b::B;\npub struct A(B);\n",
        "b.rs": (
            "pub use crate::a::A;\npub struct B;\n"
            "// crate::a::A in a comment\nconst S: &str = \"crate::a::A\";\n"
            "#[cfg(test)]\nmod tests {\n    use crate::a::A;\n}\n"
        ),
    })
    rc, out = run(import_cycles.circles, root)
    assert rc == 0 and "no import circles" in out, out


def test_long_files_are_counted_before_their_tests():
    body = "fn f() {}\n" * 601
    root = crate({
        "lib.rs": "mod long;\nmod short;\n",
        "long.rs": body,
        "short.rs": "fn f() {}\n" * 10 + "#[cfg(test)]\nmod tests {\n" + body + "}\n",
    })
    rc, out = run(import_cycles.long_files, root)
    assert rc == 1, out
    assert "601 crates/demo/src/long.rs" in out and "short.rs" not in out, out


if __name__ == "__main__":
    for name, fn in list(globals().items()):
        if name.startswith("test_"):
            fn()
            print("ok", name)
