"""The public API of the library packages carries NumPy-style docstrings (numpydoc conventions).

Pure ``ast``: no module is imported. Public = a name not starting with an underscore, defined (not
imported) in the module, at module level or as a method of a public class. Dunder methods are not
checked; ``__init__``'s parameters belong in the class docstring's ``Parameters`` section. Each
public function, method and class needs a docstring; a callable with parameters (other than
``self``/``cls``; for a class: ``__init__``'s, or a dataclass's fields) needs a ``Parameters``
section (a dataclass may use ``Attributes``); a callable whose own body has a ``return <value>``
needs a ``Returns`` (or ``Yields``) section. Properties need only a docstring.
"""

import ast
import re
from pathlib import Path

from conftest import ROOT

# Packages (directories, searched recursively) or single modules whose public API is checked.
# twin's packages are listed module by module until every module of the package passes.
CHECKED = [ROOT / "sim", ROOT / "fitting", *(ROOT / "twin" / m for m in (
    "io.py", "text.py", "html.py", "plugins.py", "arrays.py", "errors.py", "results.py",
    "effects", "model", "measurement", "firmware", "parts",
    "finding", "diagnosis", "estimation", "discovery", "datasets", "workflows",
    "reporting",
    "studies", "compensation", "cli", "calibration",
    "fleet",
))]


def _section(*names: str) -> re.Pattern:
    """A numpydoc section header: the name on its own line, underlined by dashes (any indentation)."""
    return re.compile(rf"^[ \t]*(?:{'|'.join(names)})[ \t]*\r?\n[ \t]*-{{3,}}[ \t]*$", re.MULTILINE)


PARAMETERS = _section("Parameters")
PARAMETERS_OR_ATTRIBUTES = _section("Parameters", "Attributes")
RETURNS = _section("Returns", "Yields")


def _files(entries) -> list[Path]:
    out = []
    for entry in map(Path, entries):
        found = [entry] if entry.suffix == ".py" else entry.rglob("*.py")
        out += [p for p in found if "__pycache__" not in p.parts]
    return sorted(set(out))


def _is_public(name: str) -> bool:
    return not name.startswith("_")


def _decorator_names(node) -> set[str]:
    names = set()
    for d in node.decorator_list:
        d = d.func if isinstance(d, ast.Call) else d
        if isinstance(d, ast.Attribute):
            names.add(d.attr)
        elif isinstance(d, ast.Name):
            names.add(d.id)
    return names


def _parameters(fn, is_method: bool) -> list[str]:
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args]
    if is_method and "staticmethod" not in _decorator_names(fn) and names:
        names = names[1:]  # self / cls
    names += [x.arg for x in a.kwonlyargs]
    names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    return names


def _own_nodes(fn):
    """Nodes of ``fn``'s body, not descending into nested functions, lambdas or classes."""
    nested = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)
    stack = [n for n in fn.body if not isinstance(n, nested)]
    while stack:
        node = stack.pop()
        yield node
        stack += [c for c in ast.iter_child_nodes(node) if not isinstance(c, nested)]


def _returns_value(fn) -> bool:
    return any(isinstance(n, ast.Return) and n.value is not None for n in _own_nodes(fn))


def _yields(fn) -> bool:
    return any(isinstance(n, (ast.Yield, ast.YieldFrom)) for n in _own_nodes(fn))


def _is_dataclass(cls: ast.ClassDef) -> bool:
    return "dataclass" in _decorator_names(cls)


def _dataclass_fields(cls: ast.ClassDef) -> list[str]:
    return [s.target.id for s in cls.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)
            and not (isinstance(s.annotation, ast.Name) and s.annotation.id == "ClassVar")]


def _top_level(body):
    """Definitions at module level, including those inside module-level ``if``/``try`` blocks."""
    for node in body:
        if isinstance(node, (ast.If, ast.Try)):
            yield from _top_level(node.body + node.orelse + getattr(node, "finalbody", [])
                                  + [s for h in getattr(node, "handlers", []) for s in h.body])
        else:
            yield node


def _check_function(fn, where: str, is_method: bool, problems: list[str]) -> None:
    doc = ast.get_docstring(fn)
    if not doc:
        problems.append(f"{where}: no docstring")
        return
    if {"property", "cached_property"} & _decorator_names(fn):
        return  # a one-line summary with the unit is enough
    if _parameters(fn, is_method) and not PARAMETERS.search(doc):
        problems.append(f"{where}: no 'Parameters' section")
    if (_returns_value(fn) or _yields(fn)) and not RETURNS.search(doc):
        problems.append(f"{where}: no 'Returns' (or 'Yields') section")


def _check_class(cls: ast.ClassDef, where: str, problems: list[str]) -> None:
    doc = ast.get_docstring(cls)
    if not doc:
        problems.append(f"{where}: no docstring")
    init = next((n for n in cls.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
                 and n.name == "__init__"), None)
    if doc and init is not None and _parameters(init, True) and not PARAMETERS.search(doc):
        problems.append(f"{where}: __init__ takes parameters but the class has no 'Parameters' section")
    elif doc and init is None and _is_dataclass(cls) and _dataclass_fields(cls) \
            and not PARAMETERS_OR_ATTRIBUTES.search(doc):
        problems.append(f"{where}: dataclass without a 'Parameters' or 'Attributes' section")
    for node in cls.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _is_public(node.name):
            _check_function(node, f"{where}.{node.name}", True, problems)
        elif isinstance(node, ast.ClassDef) and _is_public(node.name):
            _check_class(node, f"{where}.{node.name}", problems)


def public_api_problems(entries=CHECKED) -> tuple[int, list[str]]:
    """(number of public callables checked, one line per missing docstring or section)."""
    problems: list[str] = []
    checked = 0
    for path in _files(entries):
        rel = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(rel))
        for node in _top_level(tree.body):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _is_public(node.name):
                checked += 1
                _check_function(node, f"{rel}:{node.lineno} {node.name}", False, problems)
            elif isinstance(node, ast.ClassDef) and _is_public(node.name):
                checked += 1 + sum(isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and _is_public(n.name)
                                   for n in node.body)
                _check_class(node, f"{rel}:{node.lineno} {node.name}", problems)
    return checked, problems


def test_checked_packages_exist():
    missing = [str(p) for p in CHECKED if not Path(p).exists()]
    assert not missing, f"CHECKED lists paths that do not exist: {missing}"


def test_public_api_has_numpydoc_docstrings():
    checked, problems = public_api_problems()
    assert checked > 0
    assert not problems, (f"{len(problems)} missing docstrings or sections among {checked} public callables:\n"
                          + "\n".join(problems))


def test_the_checker_sees_what_it_should(tmp_path):
    """The checker itself: nested returns do not count, properties and dunders are exempt."""
    src = '''
def f(x):
    """Summary only."""
    return x

def g():
    """No parameters, returns nothing of its own."""
    def inner():
        return 1

class C:
    """No sections."""
    def __init__(self, a):
        self.a = a
    def __repr__(self):
        return "C"
    @property
    def p(self):
        """Value [m]."""
        return 1.0
    @staticmethod
    def s(a):
        """S.

        Parameters
        ----------
        a : float
            A [m].

        Returns
        -------
        float
            A [m].
        """
        return a
    def _private(self, b):
        return b
'''
    path = tmp_path / "mod.py"
    path.write_text(src)
    checked, problems = public_api_problems([path])
    assert checked == 5  # f, g, C, C.p, C.s
    text = "\n".join(problems)
    assert "f: no 'Parameters'" in text and "f: no 'Returns'" in text
    assert " g:" not in text and "C.p" not in text and "C.s" not in text and "__repr__" not in text
    assert "C: __init__ takes parameters" in text and len(problems) == 3
