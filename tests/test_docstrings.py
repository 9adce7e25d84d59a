"""Every public function, class and method has a numpydoc docstring with its sections.

"Public" is every name in the ``__all__`` of a public module (``docs/api_modules.py``) and the
public methods of those classes (defined in this package, not inherited from elsewhere). Each needs,
by numpydoc's own validator (:func:`numpydoc.validate.validate`):

- a docstring (GL08);
- ``Parameters`` naming every parameter (PR01);
- ``Returns`` when it returns something, ``Yields`` when it yields (RT01, YD01);
- ``Examples`` (EX01), which pytest runs as doctests (``--doctest-modules``).

Properties need a docstring only (they are attributes: no parameters, no Returns section); a
deprecated alias (``.. deprecated::`` in its docstring) is exempt. The names that still lack a
section are listed in ``tests/docstring_debt.txt``: the list may only shrink (a name fixed must
leave it; a new public name must be complete).
"""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

import numpydoc.validate

REPO = Path(__file__).resolve().parents[1]
DEBT = Path(__file__).with_name("docstring_debt.txt")
CODES = {"GL08", "PR01", "RT01", "YD01", "EX01"}


def _public_modules() -> list[str]:
    sys.path.insert(0, str(REPO / "docs"))
    try:
        import api_modules
    finally:
        sys.path.remove(str(REPO / "docs"))
    return list(api_modules.PUBLIC)


def public_objects() -> dict[str, object]:
    """Canonical dotted name (where it is defined) -> object, for every public function, class and method."""
    found: dict[str, object] = {}
    seen: set[int] = set()

    def add(name: str, obj: object) -> None:
        if id(obj) not in seen:
            seen.add(id(obj))
            found[name] = obj

    for module_name in _public_modules():
        module = importlib.import_module(module_name)
        for public in module.__all__:
            obj = getattr(module, public)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                continue
            canonical = f"{obj.__module__}.{obj.__qualname__}"
            add(canonical, obj)
            if not inspect.isclass(obj):
                continue
            for klass in obj.__mro__:
                if not klass.__module__.startswith("ffd_notebook"):
                    continue
                for attr, value in vars(klass).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(value, (staticmethod, classmethod)):
                        value = value.__func__
                    if not (inspect.isfunction(value) or isinstance(value, property)):
                        continue
                    owner = klass
                    if not value.__doc__:  # an override without its own docstring inherits the base's (as autodoc)
                        for base in klass.__mro__[1:]:
                            inherited = vars(base).get(attr)
                            if getattr(inherited, "__doc__", None):
                                owner, value = base, inherited
                                break
                    if isinstance(value, (staticmethod, classmethod)):
                        value = value.__func__
                    add(f"{owner.__module__}.{owner.__qualname__}.{attr}", value)
    return found


def missing_sections() -> dict[str, list[str]]:
    """Dotted name -> the numpydoc codes it fails among :data:`CODES` (only names that fail some)."""
    missing = {}
    for name, obj in public_objects().items():
        doc = inspect.getdoc(obj) or ""
        if ".. deprecated::" in doc:
            continue
        codes = {error[0] for error in numpydoc.validate.validate(name)["errors"]} & CODES
        if isinstance(obj, property):
            codes &= {"GL08"}
        if codes:
            missing[name] = sorted(codes)
    return missing


def _debt() -> dict[str, list[str]]:
    listed = {}
    for line in DEBT.read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.startswith("#"):
            name, codes = line.split(maxsplit=1)
            listed[name] = codes.split(",")
    return listed


def test_public_docstrings_have_their_sections():
    missing = missing_sections()
    debt = _debt()
    new = {name: codes for name, codes in missing.items() if name not in debt or set(codes) - set(debt[name])}
    paid = sorted(name for name in debt if name not in missing or set(debt[name]) - set(missing[name]))
    report = "\n".join(f"{name} {','.join(codes)}" for name, codes in sorted(new.items()))
    assert not new, f"{len(new)} public names lack numpydoc sections (GL08 docstring, PR01 Parameters, " \
        f"RT01 Returns, YD01 Yields, EX01 Examples):\n{report}"  # fmt: skip
    assert not paid, f"complete now (or gone): take them out of {DEBT.name}, the list only shrinks: {paid}"


def test_the_check_finds_a_missing_section(tmp_path, monkeypatch):
    """numpydoc's validator does report what this test relies on."""
    source = 'def f(x):\n    """Do it.\n\n    Parameters\n    ----------\n    y : int\n        Not x.\n    """\n'
    (tmp_path / "demo_doc.py").write_text(source + "    return x\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    codes = {error[0] for error in numpydoc.validate.validate("demo_doc.f")["errors"]}
    assert {"PR01", "RT01", "EX01"} <= codes


if __name__ == "__main__":  # python tests/test_docstrings.py: print the count and the list
    result = missing_sections()
    print(f"{len(public_objects())} public objects, {len(result)} lack a section")
    for dotted, failed in sorted(result.items()):
        print(dotted, ",".join(failed))
