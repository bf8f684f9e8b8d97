"""The reports' registry: every registered study has a writer, its own or its kind's, and a
study of the kinematic or sphere kind needs no line of its own."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from creatio.reports import registry as reports
from creatio.studies import registry as studies


@pytest.mark.parametrize("study_id", list(studies.STUDIES))
def test_every_registered_study_has_a_writer(study_id: str) -> None:
    """writer() finds a callable for every study; the sphere and kinematic studies without a
    line of their own get their kind's writer."""
    fn = reports.writer(study_id)
    assert callable(fn)
    if study_id not in reports.WRITERS:
        module, _, name = reports.BY_KIND[studies.get(study_id).kind.name].partition(":")
        assert (fn.__module__, fn.__name__) == (f"creatio.reports.{module}", name)


@pytest.mark.parametrize("study_id", [s for s in studies.STUDIES
                                      if (Path(reports.__file__).parent / f"{s}.py").is_file()])
def test_a_study_with_a_report_module_of_its_own_is_served_by_it(study_id: str) -> None:
    """A study whose report has a module of its own (creatio/reports/<id>.py) is written by
    it: without its line in WRITERS, its kind's writer would serve it silently (EN-03 would
    get the plain sphere report)."""
    assert reports.writer(study_id).__module__ == f"creatio.reports.{study_id}"


def test_a_new_study_of_a_kind_with_a_writer_needs_no_line(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A study added to the studies' registry alone (the sphere kind) is served by the sphere
    writer; one of a kind without a shared writer is named in the KeyError."""
    en02 = studies.get("en02")
    monkeypatch.setitem(studies.STUDIES, "en02s", dataclasses.replace(en02, id="en02s"))
    assert reports.writer("en02s") is reports.writer("en02")
    en06 = studies.get("en06")
    monkeypatch.setitem(studies.STUDIES, "en06b", dataclasses.replace(en06, id="en06b"))
    with pytest.raises(KeyError, match="en06b.*kind material"):
        reports.writer("en06b")
