"""Study file validation and stable case ids."""

from __future__ import annotations

import pytest

from cable_sim.analysis.batch.study import StudyError, study_from_dict


def _base(**kw):
    d = {"base_scene": "mooring_line", "overrides": {"n_links": 12, "wave_source": "jonswap"},
         "grid": {"wave_hs": [2.0, 3.0], "wave_seed": [1, 2, 3]}, "duration": 30.0, "transient": 5.0}
    d.update(kw)
    return d


def test_cases_and_stable_ids():
    a = study_from_dict(_base()).cases()
    b = study_from_dict(_base()).cases()
    assert len(a) == 6
    assert [c.case_id for c in a] == [c.case_id for c in b]
    assert len({c.case_id for c in a}) == 6
    assert a[0].inputs == {"wave_hs": 2.0, "wave_seed": 1}
    c = study_from_dict(_base(duration=31.0)).cases()
    assert c[0].case_id != a[0].case_id  # the duration is an input of the case
    d = study_from_dict(_base(cases=[{"wave_hs": 9.0}])).cases()
    assert len(d) == 7 and d[-1].inputs == {"wave_hs": 9.0}


@pytest.mark.parametrize("patch, key", [
    ({"grid": {"wave_hss": [1.0]}}, "grid.wave_hss"),
    ({"grid": {"wave_hs": []}}, "grid.wave_hs"),
    ({"duration": -1}, "duration"),
    ({"transient": 40.0}, "transient"),
    ({"output_interval": 0}, "output_interval"),
    ({"base_scene": "no_such_scene"}, "base_scene"),
    ({"durations": 3}, "durations"),
    ({"cases": [{"step": [1, 2]}]}, "cases[0].step"),
    ({"tn_curve": {"type": "rope"}}, "tn_curve.type"),
])
def test_errors_name_key_value_and_range(patch, key):
    with pytest.raises(StudyError if key != "tn_curve.type" else ValueError) as e:
        study_from_dict(_base(**patch))
    assert key in str(e.value)
    assert "allowed" in str(e.value)


def test_duplicate_cases_rejected():
    with pytest.raises(StudyError, match="cases"):
        study_from_dict(_base(cases=[{"wave_hs": 2.0, "wave_seed": 1}])).cases()


def test_cli_rejects_bad_study_with_exit_2(tmp_path, capsys):
    from cable_sim.analysis.batch.cli import main

    bad = tmp_path / "bad.yaml"
    bad.write_text("base_scene: mooring_line\nduration: 10\ntransient: 20\n")
    assert main([str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "transient" in err and "20" in err and "allowed" in err
    assert not (tmp_path / "out").exists()


def test_example_study_is_valid_and_small():
    from cable_sim.analysis.batch.study import load_study
    from cable_sim.scene.scenes import CONFIG_DIR

    s = load_study(CONFIG_DIR / "studies" / "example_study.yaml")
    cases = s.cases()
    assert len(cases) == 8 and s.duration * len(cases) <= 1500.0
