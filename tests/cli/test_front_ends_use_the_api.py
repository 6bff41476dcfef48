"""The add-on and the Blender batch script reach seamfit only through its public face:
``seamfit`` and the modules in ``seamfit.PUBLIC_MODULES``, and of those only the names in
their ``__all__``. Everything below them is the implementation's and may change.

The command line (``seamfit/commands``) is part of the package: it also uses the package's
own support modules (files, limits, pictures, the batch runner), but of the domains
(pattern, body, mesh, sim, opt) only what they export, never a module inside them."""
import ast
import importlib

import pytest

import seamfit
from common import REPO

FRONT_ENDS = sorted((REPO / "addon").glob("*.py")) + [REPO / "scripts" / "batch_grade.py"]
COMMANDS = REPO / "native" / "python" / "seamfit" / "commands"
DOMAINS = ("pattern", "body", "mesh", "sim", "opt")


def _public(module: str) -> set[str]:
    if module == "seamfit":
        return set(seamfit.__all__)
    return set(importlib.import_module(module).__all__)


def _module_of_call(node) -> str | None:
    """``seamfit_module("x")`` -> "seamfit.x", ``seamfit_module()`` -> "seamfit"."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "seamfit_module":
        if not node.args:
            return "seamfit"
        arg = node.args[0]
        assert isinstance(arg, ast.Constant), f"line {node.lineno}: seamfit_module takes a literal name"
        return f"seamfit.{arg.value}" if arg.value else "seamfit"
    return None


def uses(path) -> list[tuple[int, str, str | None]]:
    """(line, module, name or None for the module itself) for every use of seamfit in ``path``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "seamfit":
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                if node.module == "seamfit" and sub[len("seamfit."):] in seamfit.PUBLIC_MODULES:
                    found.append((node.lineno, sub, None))      # from seamfit import settings
                else:
                    found.append((node.lineno, node.module, alias.name))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name, None) for a in node.names if a.name.split(".")[0] == "seamfit"]
    # seamfit_module("x").name anywhere, and v = seamfit_module("x") ... v.name within a function
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _module_of_call(node.value) is not None:
            found.append((node.lineno, _module_of_call(node.value), node.attr))
        elif _module_of_call(node) is not None:
            found.append((node.lineno, _module_of_call(node), None))
    for fn in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]:
        bound = {node.targets[0].id: _module_of_call(node.value) for node in ast.walk(fn)
                 if isinstance(node, ast.Assign) and len(node.targets) == 1
                 and isinstance(node.targets[0], ast.Name) and _module_of_call(node.value) is not None}
        found += [(node.lineno, bound[node.value.id], node.attr) for node in ast.walk(fn)
                  if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound]
    return sorted(set(found), key=lambda u: (u[0], u[1], u[2] or ""))


def problems(path) -> list[str]:
    out = []
    for line, module, name in uses(path):
        where = f"{path.relative_to(REPO)}:{line}"
        if module != "seamfit" and module[len("seamfit."):] not in seamfit.PUBLIC_MODULES:
            out.append(f"{where}: {module} is not a public module")
        elif name is not None and name not in _public(module):
            out.append(f"{where}: {module}.{name} is not in its __all__")
    return out


@pytest.mark.parametrize("path", FRONT_ENDS, ids=lambda p: p.name)
def test_front_end_uses_only_the_public_api(path):
    assert problems(path) == []


def test_the_check_sees_a_private_use(tmp_path, monkeypatch):
    """The guard itself: a use below the public modules, or of a name outside ``__all__``, is named."""
    monkeypatch.setattr("test_front_ends_use_the_api.REPO", tmp_path)
    bad = tmp_path / "bad.py"
    bad.write_text('from seamfit.pattern.dxf_sizes import one_size\n'
                   'def f():\n'
                   '    io = seamfit_module("pattern")\n'
                   '    return io.reindex, seamfit_module("commands.convert"), seamfit_module().grade\n')
    assert problems(bad) == [
        "bad.py:1: seamfit.pattern.dxf_sizes is not a public module",
        "bad.py:4: seamfit.commands.convert is not a public module",
        "bad.py:4: seamfit.pattern.reindex is not in its __all__",
    ]


@pytest.mark.parametrize("module", seamfit.PUBLIC_MODULES)
def test_every_public_module_declares_what_it_offers(module):
    mod = importlib.import_module(f"seamfit.{module}")
    assert mod.__all__, module
    assert [n for n in mod.__all__ if not hasattr(mod, n)] == []


def command_problems(path) -> list[str]:
    """Relative imports of a command module that reach inside a domain or past its __all__."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if not (isinstance(node, ast.ImportFrom) and node.level == 2 and node.module):
            continue
        parts = node.module.split(".")
        if parts[0] not in DOMAINS:
            continue
        where = f"{path.name}:{node.lineno}"
        if len(parts) > 1:
            out.append(f"{where}: seamfit.{node.module} is inside a domain")
        else:
            public = _public(f"seamfit.{parts[0]}")
            out += [f"{where}: seamfit.{parts[0]}.{a.name} is not in its __all__" for a in node.names
                    if a.name not in public]
    return out


@pytest.mark.parametrize("path", sorted(COMMANDS.glob("*.py")), ids=lambda p: p.name)
def test_command_uses_only_what_the_domains_export(path):
    assert command_problems(path) == []


def test_the_command_check_sees_a_private_use(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("def run():\n    from ..pattern.dxf_sizes import one_size\n    from ..opt import reindex\n"
                   "    from ..fileio import atomic_write_text\n")
    assert command_problems(bad) == ["bad.py:2: seamfit.pattern.dxf_sizes is inside a domain",
                                     "bad.py:3: seamfit.opt.reindex is not in its __all__"]
