"""Tests of tools/import_cycles.py on small made-up crates and packages in a temporary folder.

    python3 -m unittest discover -s tools -p 'test_*.py' -v
"""

from __future__ import annotations

import contextlib
import io
import shutil
import sys
import tempfile
import textwrap
import unittest
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import import_cycles  # noqa: E402


class Repo:
    """A made-up repository: crates written from {path: text}."""

    def __init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="import-cycles-test-"))

    def crate(self, name: str, files: dict) -> Path:
        folder = self.root / "crates" / name
        (folder / "src").mkdir(parents=True)
        (folder / "Cargo.toml").write_text(f'[package]\nname = "{name}"\n')
        for rel, text in files.items():
            path = folder / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(textwrap.dedent(text))
        return folder

    def run(self, *args: str) -> tuple:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            code = import_cycles.main(["--root", str(self.root), *args])
        return code, out.getvalue()

    def close(self) -> None:
        shutil.rmtree(self.root)


def loops_of(crate: Path, **kw) -> list:
    graph = import_cycles.rust_graph(crate, crate.name, **kw)
    return [[graph.label(m) for m in c] for c in import_cycles.loops(graph)]


class RustLoops(unittest.TestCase):
    def setUp(self) -> None:
        self.repo = Repo()

    def tearDown(self) -> None:
        self.repo.close()

    def test_two_siblings_by_use(self) -> None:
        crate = self.repo.crate(
            "two",
            {
                "src/lib.rs": "mod a;\nmod b;\nmod c;\n",
                "src/a.rs": "use crate::b::B;\npub struct A;\n",
                "src/b.rs": "use crate::a::A;\npub struct B;\n",
                "src/c.rs": "use crate::a::A;\n",
            },
        )
        self.assertEqual(loops_of(crate), [["a", "b"]])

    def test_paths_in_code_count_comments_and_strings_do_not(self) -> None:
        crate = self.repo.crate(
            "paths",
            {
                "src/lib.rs": "mod a;\nmod b;\n",
                "src/a.rs": "pub fn f() { crate::b::g(); }\n",
                "src/b.rs": "pub fn g() { crate::a::f(); }\n",
            },
        )
        self.assertEqual(loops_of(crate), [["a", "b"]])
        crate = self.repo.crate(
            "quiet",
            {
                "src/lib.rs": "mod a;\nmod b;\n",
                "src/a.rs": "pub fn f() { crate::b::g(); }\n",
                "src/b.rs": textwrap.dedent(
                    """\
                    //! See [`crate::a::f`].
                    // use crate::a::f;
                    /* crate::a::f() /* nested */ crate::a::f() */
                    pub fn g() -> &'static str { let _c = '"'; let _d = '{'; "crate::a::f()" }
                    pub fn h() -> &'static str { r#"use crate::a::f; "# }
                    """
                ),
            },
        )
        self.assertEqual(loops_of(crate), [])

    def test_a_loop_around_three(self) -> None:
        crate = self.repo.crate(
            "three",
            {
                "src/lib.rs": "pub mod a;\npub mod b;\npub mod c;\n",
                "src/a.rs": "use crate::b::{self, B as Bee};\npub struct A;\n",
                "src/b.rs": "pub use crate::c::*;\npub struct B;\n",
                "src/c.rs": "pub struct C(crate::a::A);\n",
            },
        )
        self.assertEqual(loops_of(crate), [["a", "b", "c"]])

    def test_test_code_is_left_out_unless_asked(self) -> None:
        crate = self.repo.crate(
            "tests",
            {
                "src/lib.rs": "mod a;\nmod b;\n",
                "src/a.rs": "use crate::b::B;\npub struct A;\n",
                "src/b.rs": textwrap.dedent(
                    """\
                    pub struct B;
                    #[cfg(test)]
                    use crate::a::A;
                    #[cfg(test)]
                    mod tests {
                        use super::*;
                        fn brace() -> char { '}' }
                        #[test]
                        fn uses_a() { let _ = crate::a::A; }
                    }
                    #[cfg(all(test, target_arch = "x86_64"))]
                    mod more;
                    pub fn after_the_tests() {}
                    """
                ),
                "src/b/more.rs": "use crate::a::A;\n",
            },
        )
        self.assertEqual(loops_of(crate), [])
        graph = import_cycles.rust_graph(crate, "tests")
        self.assertNotIn(("b", "more"), graph.modules)
        self.assertIn("after_the_tests", import_cycles.scan_rust(crate / "src/b.rs", ("b",), "b.rs", False).definitions)
        self.assertEqual(loops_of(crate, tests=True), [["a", "b"]])

    def test_deepest_module_and_folder_named_files(self) -> None:
        crate = self.repo.crate(
            "deep",
            {
                "src/lib.rs": "pub mod video;\nmod other;\n",
                "src/video.rs": "mod probe;\nmod reader;\n",
                "src/video/probe.rs": "use crate::video::reader::Input::File;\npub struct Info;\n",
                "src/video/reader/mod.rs": "pub enum Input { File }\npub fn f() -> super::probe::Info { todo!() }\n",
                "src/other.rs": "",
            },
        )
        graph = import_cycles.rust_graph(crate, "deep")
        self.assertIn(("video", "reader"), graph.modules)
        self.assertEqual(loops_of(crate), [["video::probe", "video::reader"]])

    def test_an_import_through_a_re_export_goes_where_the_item_is(self) -> None:
        crate = self.repo.crate(
            "facade",
            {
                "src/lib.rs": "mod a;\nmod b;\nmod c;\npub use b::B;\npub use c::C;\n",
                "src/a.rs": "pub struct A(crate::B);\n",  # a -> b, through the root's re-export
                "src/b.rs": "pub struct B;\nfn f(_: crate::a::A) {}\n",
                "src/c.rs": "pub struct C(crate::B);\n",
            },
        )
        self.assertEqual(loops_of(crate), [["a", "b"]])

    def test_parent_and_child(self) -> None:
        files = {
            "src/lib.rs": "mod ops;\nmod other;\n",
            "src/ops/mod.rs": textwrap.dedent(
                """\
                mod avx2;
                mod portable;
                pub use portable::run as run_portable;
                use image::RgbImage;
                pub struct Tile;
                pub const NR: usize = 8;
                pub fn run() { avx2::tile(); }
                """
            ),
            "src/ops/avx2.rs": "use super::{Tile, NR};\npub fn tile() {}\n",
            "src/ops/portable.rs": "use super::RgbImage;\npub fn run() {}\n",
            "src/other.rs": "",
        }
        crate = self.repo.crate("kernels", files)
        # the kernels use what their front file defines: no loop, unless --parents
        self.assertEqual(loops_of(crate), [])
        self.assertEqual(loops_of(crate, parents=True), [["ops", "ops::avx2"]])
        # (portable takes only the image crate's RgbImage through its parent: no edge at all)

    def test_a_loop_that_leaves_a_folder_and_comes_back(self) -> None:
        crate = self.repo.crate(
            "folder",
            {
                "src/lib.rs": "mod conv;\nmod int8;\n",
                "src/conv.rs": "use crate::int8::Quant;\npub struct Conv;\n",
                "src/int8/mod.rs": "mod ranges;\npub use ranges::ranges;\npub struct Quant;\n",
                "src/int8/ranges.rs": "pub fn ranges() -> Option<crate::conv::Conv> { None }\n",
            },
        )
        self.assertEqual(loops_of(crate), [["conv", "int8", "int8::ranges"]])

    def test_relative_paths_and_inline_modules(self) -> None:
        crate = self.repo.crate(
            "relative",
            {
                "src/lib.rs": "mod a;\nmod b;\n",
                "src/a.rs": textwrap.dedent(
                    """\
                    mod inner {
                        pub fn f() { super::super::b::g(); }
                    }
                    """
                ),
                "src/b/mod.rs": "mod leaf;\npub fn g() { leaf::h(); }\n",
                "src/b/leaf.rs": "use crate::a;\npub fn h() { a::inner::f(); }\n",
            },
        )
        self.assertEqual(loops_of(crate), [["a", "b", "b::leaf"]])

    def test_use_tree_parsing(self) -> None:
        parsed = import_cycles.parse_use_tree("crate::{a::{self, B as C}, d::*, e}")
        self.assertEqual(
            parsed,
            [(["crate", "a"], None, False), (["crate", "a", "B"], "C", False), (["crate", "d"], None, True), (["crate", "e"], None, False)],
        )


class PythonLoops(unittest.TestCase):
    def setUp(self) -> None:
        self.repo = Repo()

    def tearDown(self) -> None:
        self.repo.close()

    def test_deferred_and_relative_imports(self) -> None:
        crate = self.repo.crate(
            "py",
            {
                "src/lib.rs": "",
                "python/pkg/__init__.py": "from ._native import Thing\n",
                "python/pkg/_native.pyi": "class Thing: ...\n",
                "python/pkg/_corpus.py": "import pkg\n\ndef f():\n    from pkg.daft import DTYPE\n    return DTYPE\n",
                "python/pkg/daft.py": "import daft\nimport pkg\nDTYPE = 1\n\ndef g():\n    from . import _corpus\n",
                "python/pkg/sub/__init__.py": "from .. import daft\n",
                "python/pkg/sub/leaf.py": "from ..sub import other\n",
            },
        )
        graph = import_cycles.python_graph(crate / "python" / "pkg", crate, "py")
        self.assertEqual(
            [[graph.label(m) for m in c] for c in import_cycles.loops(graph)],
            [["pkg._corpus", "pkg.daft"]],
        )
        code, out = self.repo.run("py")
        self.assertEqual(code, 1)
        self.assertIn("loop 1, 2 modules: pkg._corpus, pkg.daft", out)
        self.assertIn("pkg.daft -> pkg._corpus: python/pkg/daft.py:6: from . import _corpus", out)


class CommandLine(unittest.TestCase):
    def setUp(self) -> None:
        self.repo = Repo()
        self.repo.crate("clean", {"src/lib.rs": "mod a;\n", "src/a.rs": ""})
        self.repo.crate(
            "knotted",
            {"src/main.rs": "mod a;\nmod b;\n", "src/a.rs": "use crate::b::B;\npub struct A;", "src/b.rs": "pub struct B(crate::a::A);"},
        )

    def tearDown(self) -> None:
        self.repo.close()

    def test_every_crate(self) -> None:
        code, out = self.repo.run()
        self.assertEqual(code, 1)
        self.assertIn("crates/clean (Rust), 2 modules: no loops", out)
        self.assertIn("crates/knotted (Rust), 3 modules: 1 loop(s)", out)
        self.assertIn("    a -> b: src/a.rs:1: use crate::b::B", out)
        self.assertIn("    b -> a: src/b.rs:1: crate::a::A", out)
        self.assertIn("import loops: 1 in 2 crates and packages checked", out)

    def test_given_and_excluded_crates(self) -> None:
        code, out = self.repo.run("clean")
        self.assertEqual(code, 0)
        self.assertNotIn("knotted", out)
        self.assertIn("import loops: none in 1 crates and packages checked", out)
        code, out = self.repo.run("--exclude", "crates/knotted")
        self.assertEqual(code, 0)
        self.assertIn("not checked: crates/knotted", out)
        with contextlib.redirect_stderr(io.StringIO()), self.assertRaises(SystemExit) as e:
            self.repo.run("nonesuch")
        self.assertEqual(e.exception.code, 2)


class Layers(unittest.TestCase):
    """--layers: an import from a layer to one above it is refused, even without a loop."""

    def setUp(self) -> None:
        self.repo = Repo()
        self.repo.crate(
            "layered",
            {
                "src/lib.rs": "mod base;\nmod stages;\nmod engine;\npub use base::data::Data;\n",
                "src/base/mod.rs": "pub mod data;\n",
                "src/base/data.rs": "pub struct Data;\n",
                "src/stages/mod.rs": "pub mod crop;\n",
                # through the root's re-export: the edge goes to base::data
                "src/stages/crop.rs": "use crate::Data;\npub fn crop(_: Data) {}\n",
                "src/engine.rs": "use crate::stages::crop::crop;\n",
            },
        )

    def tearDown(self) -> None:
        self.repo.close()

    def test_imports_downwards_pass(self) -> None:
        code, out = self.repo.run("--layers", "layered=base,stages", "layered")
        self.assertEqual(code, 0, out)
        self.assertIn("layers base < stages < the rest: no import reaches up", out)

    def test_an_import_up_is_refused_without_a_loop(self) -> None:
        data = self.repo.root / "crates" / "layered" / "src" / "base" / "data.rs"
        data.write_text("pub struct Data;\npub fn make() { crate::engine::go() }\n")
        (self.repo.root / "crates" / "layered" / "src" / "engine.rs").write_text("pub fn go() {}\n")
        code, out = self.repo.run("--layers", "layered=base,stages", "layered")
        self.assertEqual(code, 1, out)
        self.assertIn("no loops", out)
        self.assertIn("1 import(s) reach up", out)
        self.assertIn("    base::data -> engine: src/base/data.rs:2: crate::engine::go", out)
        # the same layers in the other order: the middle now imports the bottom's top
        code, out = self.repo.run("--layers", "layered=stages,base", "layered")
        self.assertEqual(code, 1, out)
        self.assertIn("    stages::crop -> base::data:", out)

    def test_a_layers_argument_without_layers_is_refused(self) -> None:
        with contextlib.redirect_stderr(io.StringIO()), self.assertRaises(SystemExit) as e:
            self.repo.run("--layers", "layered")
        self.assertEqual(e.exception.code, 2)


if __name__ == "__main__":
    unittest.main()
