"""Where an elastix file's ``InitialTransformParameterFileName`` is looked for (issue 35 item 9, issue 36).

Before: the name was looked for as written (relative to the working folder) before beside the file, so a stray
``TransformParameters.0.txt`` in a notebook's folder was chained instead of the one beside the file, silently (a
shift of 100 instead of 1). Now the file beside it comes first, and when both exist and differ the chain is
refused; with ``within`` the chain stays in that folder and a name outside it gets one answer, exist or not.
"""

from __future__ import annotations

import pytest

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_deformation, load_elastix


def _translation(path, shift, initial="NoInitialTransform"):
    path.write_text(f'(Transform "TranslationTransform")\n(TransformParameters {shift} 0 0)\n'
                    f'(InitialTransformParameterFileName "{initial}")\n')  # fmt: skip


@pytest.fixture()
def run(tmp_path, monkeypatch):
    """A results folder with a two-file chain, and a notebook folder (the working folder) elsewhere."""
    results, notebook = tmp_path / "results", tmp_path / "notebook"
    results.mkdir()
    notebook.mkdir()
    _translation(results / "TransformParameters.0.txt", 1.0)
    _translation(results / "TransformParameters.1.txt", 0.5, "TransformParameters.0.txt")
    monkeypatch.chdir(notebook)
    return results, notebook


def test_the_file_beside_it_is_chained(run):
    results, _ = run
    assert load_elastix(results / "TransformParameters.1.txt").deform([[0.0, 0.0, 0.0]]).tolist() == [[1.5, 0, 0]]


def test_a_stray_file_in_the_working_folder_that_differs_is_refused(run):
    results, notebook = run
    _translation(notebook / "TransformParameters.0.txt", 100.0)  # before: chained silently, a shift of 100.5
    with pytest.raises(FileFormatError, match="both beside this file and in the working folder") as info:
        load_elastix(results / "TransformParameters.1.txt")
    assert info.value.line == 3
    (notebook / "TransformParameters.0.txt").write_bytes((results / "TransformParameters.0.txt").read_bytes())
    assert load_elastix(results / "TransformParameters.1.txt").deform([[0.0, 0.0, 0.0]]).tolist() == [[1.5, 0, 0]]


def test_the_working_folder_is_still_looked_in(run):
    """elastix's other rule: a name relative to where elastix ran, found there when nothing is beside the file."""
    results, notebook = run
    (results / "TransformParameters.0.txt").rename(notebook / "TransformParameters.0.txt")
    assert load_elastix(results / "TransformParameters.1.txt").deform([[0.0, 0.0, 0.0]]).tolist() == [[1.5, 0, 0]]


def test_within_a_folder_a_name_outside_gets_one_answer(run, tmp_path):
    results, _ = run
    outside = tmp_path / "outside"
    outside.mkdir()
    _translation(outside / "exists.txt", 7.0)
    answers = []
    for target in (outside / "exists.txt", outside / "missing.txt", "../outside/exists.txt", "/etc/passwd"):
        _translation(results / "probe.txt", 0.0, str(target))
        with pytest.raises(FileFormatError, match="not in the folder this file may read from") as info:
            load_deformation(results / "probe.txt", within=results)
        answers.append(info.value.problem.split("(")[0])
    assert len(set(answers)) == 1, answers
    chain = load_elastix(results / "TransformParameters.1.txt", within=results)  # inside: the chain is read
    assert chain.deform([[0.0, 0.0, 0.0]]).tolist() == [[1.5, 0.0, 0.0]]
