# SPDX-License-Identifier: MIT
"""The package's types: the stub of the compiled module (_imucal.pyi) says what the module is, the
package type-checks under mypy --strict, a user's code is checked against it (a wrong call is an
error), and every public function documents every argument.

mypy (Debian: python3-mypy) is needed; without it these tests skip, unless IMUCAL_REQUIRE_MYPY
is set (tools/test_python.sh sets it)."""
import ast
import inspect
import os
import re
import subprocess
import sys
import tempfile

import pytest

import imucal
from imucal import _imucal

STUB = os.path.join(os.path.dirname(os.path.abspath(imucal.__file__)), "_imucal.pyi")


def signature_from_text(text):
    """The ast of `def NAME(ARGS) -> RET: ...` for a signature line."""
    return ast.parse("def " + text + ": ...").body[0]


def parameters(fn):
    """(name, kind, default, annotation) of each parameter, self left out; kinds positional or
    keyword-only; default and annotation as source text (None: none)."""
    a = fn.args
    out = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + a.defaults
    for arg, default in zip(positional, defaults):
        out.append((arg.arg, "positional", default, arg.annotation))
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        out.append((arg.arg, "keyword", default, arg.annotation))
    return [(name, kind, None if d is None else ast.unparse(d),
             None if t is None else ast.unparse(t)) for name, kind, d, t in out if name != "self"]


def base_type(annotation):
    """A type's outer name, as pybind11 and a stub may both spell it: List[str] -> list,
    Optional[X] -> X's, numpy.ndarray[...] -> ndarray."""
    if annotation is None:
        return None
    if annotation.startswith("Optional["):
        annotation = annotation[len("Optional["):-1]
    return annotation.split("[")[0].split(".")[-1].lower()


def same_types(runtime, stub):
    """pybind11's `object` is any type; otherwise the outer names agree."""
    return runtime == "object" or base_type(runtime) == base_type(stub)


def stub_functions():
    """The stub's functions, by qualified name (Corrector.apply)."""
    with open(STUB) as f:
        tree = ast.parse(f.read())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out[node.name] = node
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    out[node.name + "." + item.name] = item
    return tree, out


def runtime_function(qualified):
    obj = _imucal
    for part in qualified.split("."):
        obj = getattr(obj, part)
    return obj


def test_the_stub_is_the_compiled_modules_signatures():
    """Every function and method of imucal._imucal is in the stub with the same parameters
    (names, order, kind, defaults) and compatible types, as pybind11's signatures give them, and
    the stub has nothing the module lacks."""
    tree, functions = stub_functions()
    runtime_names = {n for n in dir(_imucal) if not n.startswith("_")}
    stub_names = {node.name for node in tree.body if isinstance(node, (ast.FunctionDef,
                                                                       ast.ClassDef))}
    stub_names |= {node.target.id for node in tree.body if isinstance(node, ast.AnnAssign)}
    assert stub_names - {"__version__"} == runtime_names
    assert {"Corrector.__init__", "Corrector.apply"} <= set(functions)
    for qualified, stub in functions.items():
        doc = runtime_function(qualified).__doc__
        runtime = signature_from_text(doc.splitlines()[0])
        assert runtime.name == qualified.split(".")[-1]
        got, want = parameters(runtime), parameters(stub)
        assert [p[:3] for p in got] == [p[:3] for p in want], qualified
        for (name, _, _, rt), (_, _, _, st) in zip(got, want):
            assert same_types(rt, st), (qualified, name, rt, st)
        assert same_types(ast.unparse(runtime.returns), ast.unparse(stub.returns)), qualified
    assert isinstance(_imucal.__version__, str)
    assert isinstance(_imucal.ACCEL_PARAMETERS, tuple)
    assert all(isinstance(n, str) for n in _imucal.GYRO_PARAMETERS)


def test_a_stub_that_differs_is_caught():
    """The comparison above fails on a renamed parameter, a lost default and a wrong type."""
    runtime = signature_from_text(
        "apply(self: imucal._imucal.Corrector, acc: object, gyro: object, temp: object = None) "
        "-> tuple")
    for wrong in ("apply(self, acc: X, gyros: X, temp: X = None) -> Tuple[X, X]",
                  "apply(self, acc: X, gyro: X, temp: X) -> Tuple[X, X]",
                  "apply(self, acc: X, *, gyro: X, temp: X = None) -> Tuple[X, X]"):
        assert [p[:3] for p in parameters(runtime)] != \
            [p[:3] for p in parameters(signature_from_text(wrong))]
    assert not same_types("List[str]", "Dict[str, str]")
    assert not same_types("tuple", "bytes")
    assert same_types("List[str]", "List[str]") and same_types("bytes", "Optional[bytes]")


def public_callables():
    return {"calibrate": imucal.calibrate, "noise": imucal.noise,
            "decode_record": imucal.decode_record, "Corrector": imucal.Corrector.__init__,
            "Corrector.apply": imucal.Corrector.apply}


def test_every_argument_is_explicit_and_documented():
    """No **kwargs: every option is a named parameter with a default where it is optional, and
    its name is in the function's docstring (the class's for a constructor)."""
    for name, fn in public_callables().items():
        doc = (imucal.Corrector.__doc__ or "") + (fn.__doc__ or "")
        for p in inspect.signature(fn).parameters.values():
            if p.name == "self":
                continue
            assert p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL), (name, p.name)
            assert p.annotation is not inspect.Parameter.empty, (name, p.name)
            assert (" " + p.name) in doc.replace("\n", " ") or doc.startswith(p.name), \
                (name, p.name)
    for name in imucal.__all__:
        obj = getattr(imucal, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            assert obj.__doc__, name


def mypy():
    """mypy --strict as a function of its arguments: (exit code, output). It finds imucal where
    Python imports it from: site-packages, or the folder on MYPYPATH (a build folder)."""
    try:
        import mypy  # noqa: F401
    except ImportError:
        if os.environ.get("IMUCAL_REQUIRE_MYPY"):
            pytest.fail("mypy is not installed (Debian: python3-mypy)")
        pytest.skip("mypy is not installed (Debian: python3-mypy)")
    where = os.path.dirname(os.path.dirname(os.path.abspath(imucal.__file__)))
    env = dict(os.environ)
    if os.path.basename(where) != "site-packages":
        env["MYPYPATH"] = where

    def run(*args):
        with tempfile.TemporaryDirectory() as cache:
            r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--cache-dir", cache,
                                *args], capture_output=True, text=True, env=env)
        return r.returncode, r.stdout + r.stderr
    return run


def test_the_package_type_checks_strictly():
    """mypy --strict on the package as imported (the installed one under tools/test_python.sh):
    its Python code against the compiled module's stub."""
    code, out = mypy()("-p", "imucal")
    assert code == 0, out
    assert "Success: no issues found in 3 source files" in out, out


USE = """
from typing import Optional, Tuple

import numpy as np
import numpy.typing as npt
import imucal

acc = np.zeros((10, 3))
r: imucal.Calibration = imucal.calibrate(acc, acc, t=np.arange(10.0), gravity=9.81,
                                         accel_range=(0.0, 65535.0), temp_order=2)
if r.accelerometer is not None:
    s: float = r.accelerometer["s_x"]
    v: npt.NDArray[np.float64] = r.accelerometer.values
if r.magnetometer is not None:
    h: npt.NDArray[np.float64] = r.magnetometer.hard_iron
record: Optional[bytes] = r.record
n: imucal.Noise = imucal.noise(gyro=acc, rate=100.0, gyro_unit="dps")
rec: imucal.Record = imucal.decode_record(b"")
a, w = imucal.Corrector(b"").apply(acc, acc, temp=np.zeros(10))
names: Tuple[str, ...] = imucal.ACCEL_PARAMETERS
"""

MISUSE = [  # a line, the error mypy must report on it
    ('imucal.calibrate(acc, gravity="9.81")', "arg-type"),
    ("imucal.calibrate(acc, gravityy=9.81)", "call-arg"),
    ('imucal.calibrate(acc, accel_unit="furlongs")', "arg-type"),
    ("imucal.calibrate(acc, temp_order=3)", "arg-type"),
    ("imucal.calibrate(acc, acc, acc)", "misc"),
    ("imucal.calibrate(acc).accelerometer.values", "union-attr"),
    ("x: str = imucal.noise(acc, rate=100.0).rate_hz", "assignment"),
    ("imucal.decode_record(acc)", "arg-type"),
]


def test_a_users_code_is_checked_against_the_types():
    """Code using the API as documented checks clean; each misuse is reported on its line."""
    run = mypy()
    header = ["import numpy as np", "import imucal", "acc = np.zeros((10, 3))"]
    with tempfile.TemporaryDirectory() as d:
        use, misuse = os.path.join(d, "use.py"), os.path.join(d, "misuse.py")
        with open(use, "w") as f:
            f.write(USE)
        with open(misuse, "w") as f:
            f.write("\n".join(header + [line for line, _ in MISUSE]) + "\n")
        code, out = run(use)
        assert code == 0, out
        code, out = run(misuse)
    assert code == 1, out
    found = {int(m[1]): m[2] for m in re.finditer(r"misuse\.py:(\d+): error: .*\[([a-z-]+)\]$",
                                                   out, re.M)}
    assert found == {len(header) + k + 1: error for k, (_, error) in enumerate(MISUSE)}, out


def test_stubtest_finds_the_stub_consistent():
    """mypy's stubtest: the stub's names and kinds against the imported module (pybind11's
    classes have their own metaclass, which a stub does not spell)."""
    mypy()
    with tempfile.TemporaryDirectory() as d:
        allow = os.path.join(d, "allow.txt")
        with open(allow, "w") as f:
            f.write("imucal._imucal.Corrector\n")
        r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "--allowlist", allow,
                            "imucal._imucal"], capture_output=True, text=True, cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
