"""The type stubs describe the module as it is: every name, and every function's and
method's parameters in order, with their defaults where the stub states them."""

import ast
import inspect
from pathlib import Path

import svo
import svo._svo as native

STUB = Path(svo.__file__).with_name("_svo.pyi")


def stub_functions(tree):
    """(owner, name, [parameter names], {name: default}) for every def in the stub."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            yield None, node
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    yield node.name, item


def test_every_name_and_signature():
    tree = ast.parse(STUB.read_text())
    names = {n.name for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))}
    names |= {t.id for n in tree.body if isinstance(n, ast.AnnAssign) for t in [n.target]}
    assert names - {"_Path", "_Points", "_Vec3"} == set(svo.__all__)
    checked = 0
    for owner, fn in stub_functions(tree):
        obj = getattr(native, owner) if owner else native
        runtime = getattr(obj, fn.name)
        if not callable(runtime) or fn.name.startswith("__"):
            continue
        params = list(inspect.signature(runtime).parameters.values())
        stub_args = fn.args.args
        if owner and stub_args and stub_args[0].arg == "self":
            stub_args = stub_args[1:]
            params = [p for p in params if p.name != "self"]
        assert [a.arg for a in stub_args] == [p.name for p in params], f"{owner}.{fn.name}"
        defaults = dict(zip([a.arg for a in stub_args][-len(fn.args.defaults or []):], fn.args.defaults))
        for p in params:
            d = defaults.get(p.name)
            if d is None or (isinstance(d, ast.Constant) and d.value is Ellipsis):
                continue
            expected = eval(ast.unparse(d))  # constants and `2**30`
            assert p.default == expected, f"{owner}.{fn.name}({p.name})"
        checked += 1
    assert checked >= 15


def test_docstrings_for_help():
    for obj in [svo.Mesh, svo.Octree, svo.Hits, svo.bake, svo.Octree.cast, svo.Octree.render,
                svo.Mesh.load, svo.Octree.load, svo.MeshError, svo.FormatError]:
        assert obj.__doc__ and len(obj.__doc__) > 40, obj
