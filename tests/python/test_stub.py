"""The type stubs (python/gimm/_gimm.pyi) name what the module has, with its parameters."""
import ast
import inspect
import os
import unittest

import gimm
import gimm._gimm as native


def stub():
    path = os.path.join(os.path.dirname(gimm.__file__), "_gimm.pyi")
    with open(path) as f:
        return ast.parse(f.read())


def params(node):
    a = node.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg != "self"]
    return names + (["**" + a.kwarg.arg] if a.kwarg else [])


def documented_params(obj):
    """Parameter names of a pybind11 function from its docstring's first signature line."""
    line = (obj.__doc__ or "").splitlines()[0]
    inside = line[line.index("(") + 1:line.rindex(")")] if "(" in line else ""
    names, depth, current = [], 0, ""
    for ch in inside + ",":
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        if ch == "," and depth == 0:
            name = current.split(":")[0].strip()
            if name and name not in ("self", "*"):
                names.append(name)
            current = ""
        else:
            current += ch
    return names


class Stubs(unittest.TestCase):
    def test_every_public_name_is_in_the_stub_and_back(self):
        tree = stub()
        names = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
        names |= {t.id for n in tree.body if isinstance(n, ast.AnnAssign)
                  for t in [n.target] if isinstance(t, ast.Name)}
        public = {n for n in dir(native) if not n.startswith("_")} | {"__version__"}
        helpers = {"Geometry", "Centerlines"}  # typing-only names of the stub
        optional = {"read_xa_dicom", "write_xa_dicom"}  # only in a build with GDCM
        self.assertEqual(public - names, set(), "missing from the stub")
        self.assertEqual(names - public - helpers - optional, set(),
                         "in the stub but not in the module")

    def test_function_parameters_match(self):
        for node in stub().body:
            if isinstance(node, ast.FunctionDef) and hasattr(native, node.name):
                self.assertEqual(params(node), documented_params(getattr(native, node.name)),
                                 node.name)
            if isinstance(node, ast.ClassDef) and hasattr(native, node.name):
                cls = getattr(native, node.name)
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and not any(
                            isinstance(d, ast.Name) and d.id == "property"
                            for d in item.decorator_list):
                        member = getattr(cls, item.name)
                        if inspect.isroutine(member) and member.__doc__:
                            self.assertEqual(params(item), documented_params(member),
                                             f"{node.name}.{item.name}")


if __name__ == "__main__":
    unittest.main()
