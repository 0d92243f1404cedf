"""scripts/metrics.py's structure rules on small packages written here: the lineage of a class,
comparisons against a servo family name and import circles (static, every kind of import)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from textwrap import dedent

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("dxl_metrics", ROOT / "scripts" / "metrics.py")
assert _spec is not None and _spec.loader is not None
metrics = importlib.util.module_from_spec(_spec)
sys.modules["dxl_metrics"] = metrics
_spec.loader.exec_module(metrics)


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for name, text in {"__init__.py": "", **files}.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        (path.parent / "__init__.py").touch()
        path.write_text(dedent(text))
    return root


def _lineages(root: Path) -> dict[str, tuple[list[str], int]]:
    return metrics.lineages(metrics.load_package(root))


def test_lineage_follows_in_package_bases_through_imports_and_re_exports(tmp_path):
    root = _package(tmp_path, {
        "base.py": """\
            class Root:
                pass
            """,
        "sub/__init__.py": "from ..base import Root as Renamed\n",
        "sub/mid.py": """\
            import threading
            from ..sub import Renamed
            class Mid(Renamed, threading.Thread):
                x = 1
                y = 2
            """,
        "top.py": """\
            from .sub import mid
            class Top(mid.Mid, dict):
                pass
            class Alone:
                pass
            """,
    })
    found = _lineages(root)
    chain, lines = found["pkg.top.Top"]
    assert chain == ["pkg.top.Top", "pkg.sub.mid.Mid", "pkg.base.Root"]  # threading.Thread and dict do not count
    assert lines == 2 + 3 + 2
    assert found["pkg.top.Alone"] == (["pkg.top.Alone"], 2)


def test_lineage_rule_counts_classes_and_lines(tmp_path):
    four = "class A:\n    pass\nclass B(A):\n    pass\nclass C(B):\n    pass\nclass D(C):\n    pass\n"
    long = "class E:\n" + "    x = 1\n" * 398 + "class F(E):\n    pass\n"  # 399 + 2 lines
    _, fig = metrics.structure(_package(tmp_path, {"four.py": four, "long.py": long}))
    assert fig["lineages"] == 2  # D (4 classes) and F (401 lines); E alone has 399
    assert fig["longest_lineage"] == 4 and fig["largest_lineage_lines"] == 401
    assert metrics.structure_broken(fig)


@pytest.mark.parametrize("text, count", [
    ('if model.series == "X":\n    pass\n', 1),
    ('ok = "PRO" != series\n', 1),
    ('ok = series in ("P", "Pro")\n', 1),
    ('ok = series not in ["X"] and a == b\n', 1),
    ('ok = 0 < a == "X" < 3\n', 1),                   # one comparison expression, one count
    ('match series:\n    case "Pro":\n        pass\n    case "x":\n        pass\n', 1),
    ('NAMES = {"X": 1, "PRO": 2}\nname = NAMES["X"]\n', 0),  # keys and look-ups are no comparisons
    ('ok = series == "XM430" or series.startswith("X")\n', 0),
    ('ok = series in NAMES\n', 0),
    ('ok = series == "x"\n', 0),                      # only the spellings X, P, PRO and Pro
])
def test_family_comparisons(text, count):
    import ast
    assert len(metrics.family_comparisons(ast.parse(text))) == count


def test_family_comparisons_in_the_control_table_are_free(tmp_path):
    same = 'def f(s):\n    return s == "X" or s == "P" or s == "PRO"\n'
    _, fig = metrics.structure(_package(tmp_path, {"control_table/fam.py": same}))
    assert fig["family_comparisons"] == 0
    _, fig = metrics.structure(_package(tmp_path / "b", {"other.py": same}))
    assert fig["family_comparisons"] == 3 and metrics.structure_broken(fig)


def test_import_circles_count_type_checking_and_function_level_imports(tmp_path):
    root = _package(tmp_path, {
        "a.py": "from . import b\n",
        "b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .c import C\n",
        "c.py": "def f():\n    from .a import thing\n    return thing\nC = 1\n",
        "d.py": "import pkg.e\n",
        "e.py": "try:\n    from .d import x\nexcept ImportError:\n    x = None\n",
        "f.py": "from .sub import g\n",   # the submodule, not the package: no circle with sub/__init__
        "sub/__init__.py": "from ..f import y\n",
        "sub/g.py": "",
    })
    graph = metrics.import_graph(metrics.load_package(root))
    assert graph["pkg.f"] == {"pkg.sub.g"}
    assert metrics.circles(graph) == [["pkg.a", "pkg.b", "pkg.c"], ["pkg.d", "pkg.e"]]
    _, fig = metrics.structure(root)
    assert fig["import_circles"] == 2 and metrics.structure_broken(fig)


def test_a_package_without_offenders_passes(tmp_path):
    root = _package(tmp_path, {"a.py": "from . import b\nclass A:\n    pass\n", "b.py": "class B:\n    pass\n"})
    found, fig = metrics.structure(root)
    assert found == [] and not metrics.structure_broken(fig)


def test_check_fails_on_structure_only_with_the_flag(tmp_path, capsys):
    root = _package(tmp_path, {"a.py": "from . import b\n", "b.py": "from . import a\n"})
    assert metrics.main(["--check", str(root)]) == 0
    assert metrics.main(["--check", "--structure", str(root)]) == 1
    assert "import circles: 1" in capsys.readouterr().out


def test_one_line_forwards_of_a_front_are_counted_and_more_than_allowed_fail(tmp_path, monkeypatch):
    root = _package(tmp_path, {"loop.py": """\
        class Handler:
            def step(self):
                return self.steps.step()
            def put(self, dxl_id, value):
                \"\"\"A docstring does not make it more than a forward.\"\"\"
                self.part.put(dxl_id, value)
            @property
            def count(self):
                return self.steps.count
            def changed(self, dxl_id):
                return self.part.put(dxl_id + 1)
            def two(self, dxl_id):
                self.part.put(dxl_id)
                return self.part.get(dxl_id)
            def own(self):
                return self.value
        class Other:
            def step(self):
                return self.steps.step()
        """})
    monkeypatch.setattr(metrics, "FRONTS", {("loop", "Handler"): 3})
    found, fig = metrics.structure(root)
    assert fig["forwards loop.Handler"] == 3 and not metrics.structure_broken(fig)  # step, put, count
    monkeypatch.setattr(metrics, "FRONTS", {("loop", "Handler"): 2})
    found, fig = metrics.structure(root)
    assert found == ["loop.Handler: 3 one-line forwards (at most 2)"] and metrics.structure_broken(fig)


def test_parameter_names_looked_up_outside_config_are_counted(tmp_path, monkeypatch):
    root = _package(tmp_path, {
        "config.py": """\
            SCHEMA = (_p("baudrate", 1), _p("dyn_comm/retry_num", 2), *(_p(f"pub_ratio/{g}", 3) for g in "ab"))
            x = values["baudrate"]
            """,
        "node.py": """\
            a = config["baudrate"]
            b = values.get("dyn_comm/retry_num")
            c = node.get_parameter(f"pub_ratio/{group}")
            d = config["unrelated"]
            e = settings.baudrate
            """,
    })
    monkeypatch.setattr(metrics, "PARAM_LOOKUPS", 3)
    found, fig = metrics.structure(root)
    assert fig["param_lookups"] == 3 and not metrics.structure_broken(fig)  # config.py's own is exempt
    assert [line.rsplit(":", 2)[1] for line in found] == ["1", "2", "3"]
    monkeypatch.setattr(metrics, "PARAM_LOOKUPS", 2)
    assert metrics.structure_broken(metrics.structure(root)[1])


@pytest.mark.parametrize("text, count", [
    ("handler.register(Note, self._note)\n", 1),        # a part putting its own route in another's table
    ("self.h.attach(self)\n", 1),
    ("intake.attach(self)\n", 1),
    ("atexit.register(close)\n", 0),
    ("self.handler.attach(self.commander)\n", 0),      # the assembler attaching what it built
    ("joint_states.attach(self)\n", 0),                # a ROS module's attach(node): no intake
])
def test_runtime_registrations(text, count):
    import ast
    assert len(metrics.runtime_registrations(ast.parse(text))) == count


@pytest.mark.parametrize("text, count", [
    ("if framer.version == 2:\n    pass\n", 1),
    ("x = a if protocol == 1 else b\n", 1),
    ("ok = 2 != servo.protocol\n", 1),
    ("ok = model.protocol in (1, 2)\n", 1),
    ("ok = table.version != self._built_for\n", 0),     # a version that is no protocol number
    ("ok = count == 2\n", 0),
])
def test_protocol_branches(text, count):
    import ast
    assert len(metrics.protocol_branches(ast.parse(text))) == count


def test_protocol_branches_in_the_family_objects_and_framers_are_free(tmp_path):
    same = "def f(p):\n    return p.protocol == 1\n"
    _, fig = metrics.structure(_package(tmp_path, {"control_table/fam.py": same, "protocol/framers.py": same}))
    assert fig["protocol_branches"] == 0
    _, fig = metrics.structure(_package(tmp_path / "b", {"bus/reads.py": same}))
    assert fig["protocol_branches"] == 1


def test_two_level_forwards_count(tmp_path):
    front = ("class DynamixelBus:\n"
             "    def device(self):\n        return self._t.port.device\n"
             "    def close(self):\n        self._t.port.close()\n"
             "    def read(self, a):\n        return self.reads.read(a)\n"
             "    def other(self, a):\n        return self.reads.read(a + 1)\n")
    _, fig = metrics.structure(_package(tmp_path, {"bus/core.py": front}))
    assert fig["forwards bus.core.DynamixelBus"] == 3
