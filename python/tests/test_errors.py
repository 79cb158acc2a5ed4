"""Errors of the library reach Python as SlipbayesError (a ValueError) with the messages the
command line prints: the file, line, column or key at fault."""

import pytest

import slipbayes
from conftest import ONE_CONTACT_TOML, DATA, one_contact


def test_error_is_a_value_error():
    assert issubclass(slipbayes.SlipbayesError, ValueError)


def test_a_model_file_that_does_not_parse_names_file_line_and_column(tmp_path):
    path = tmp_path / "bad.toml"
    text = ONE_CONTACT_TOML.format(data=DATA.as_posix())
    text = text.replace('velocity_m_per_s = 1e-9\nscene = "repeat"',
                        'velocity_m_per_s = "fast"\nscene = "repeat"')
    path.write_text(text)
    line = text.splitlines().index('velocity_m_per_s = "fast"') + 1
    with pytest.raises(slipbayes.SlipbayesError) as info:
        slipbayes.fit(path, steps=10, progress=False)
    message = str(info.value)
    assert str(path) in message
    # The library's message names the line and column of the bad value, and the key.
    assert f"line {line}, column 20" in message and "velocity_m_per_s" in message
    assert 'expected f64' in message


def test_an_invalid_value_names_the_key(tmp_path):
    model = one_contact()
    model["run"][0]["velocity_m_per_s"] = -1e-9
    with pytest.raises(slipbayes.SlipbayesError, match=r"run\[0\]\.velocity_m_per_s"):
        slipbayes.fit(model, steps=10, progress=False)
    model = one_contact()
    model["run"][1]["contact"] = "nowhere"
    with pytest.raises(slipbayes.SlipbayesError, match="nowhere"):
        slipbayes.fit(model, steps=10, progress=False)


def test_a_dict_of_the_wrong_shape_names_the_key_path_not_a_line():
    model = one_contact()
    model["run"][1]["velocity_m_per_s"] = "fast"
    with pytest.raises(slipbayes.SlipbayesError) as info:
        slipbayes.fit(model, steps=10, progress=False)
    message = str(info.value)
    assert 'run[1].velocity_m_per_s: invalid type: string "fast", expected f64' in message
    # The dict has no lines: none are named (the TOML made from it had them).
    assert "line" not in message and "<model dict>" in message
    model = one_contact()
    model["priors"] = {"alpha": {"dist": "log-normal", "mu": 1.0}}
    with pytest.raises(slipbayes.SlipbayesError, match=r"priors\.alpha: unknown field `mu`"):
        slipbayes.fit(model, steps=10, progress=False)
    model = one_contact()
    model["sampler"] = {"seed": 1.5}
    with pytest.raises(slipbayes.SlipbayesError, match=r"sampler\.seed: invalid type"):
        slipbayes.fit(model, steps=10, progress=False)


def test_a_missing_data_file_names_the_file(tmp_path):
    missing = tmp_path / "missing.csv"
    with pytest.raises(slipbayes.SlipbayesError, match="missing.csv"):
        slipbayes.fit(one_contact(first=str(missing)), steps=10, progress=False)


def test_a_run_dir_without_a_run(tmp_path):
    with pytest.raises(slipbayes.SlipbayesError, match="summary.json"):
        slipbayes.load(tmp_path)


def test_law_names_the_parameter_and_element():
    with pytest.raises(slipbayes.SlipbayesError, match=r"element 1: parameter t0 = -1e0"):
        slipbayes.law([20.0, 30.0], alpha_per_m=1e6, a_n=1e-3, f_d_n=1e-2,
                      t0_s=[1.0, -1.0], velocity_m_per_s=1e-9)


def test_fit_into_a_folder_of_the_users_refuses_and_overwrite_keeps_its_other_files(tmp_path):
    paper = tmp_path / "paper"
    paper.mkdir()
    for name in ("summary.json", "report.html", "notes.txt"):
        (paper / name).write_text(f"the user's {name}")
    model = one_contact()
    with pytest.raises(slipbayes.SlipbayesError,
                       match=r"(?s)paper.*would replace report\.html, summary\.json.*--overwrite"):
        slipbayes.fit(model, steps=100, out=paper, progress=False)
    # Nothing was written, not even the dict's data or the lock.
    assert sorted(p.name for p in paper.iterdir()) == ["notes.txt", "report.html", "summary.json"]
    slipbayes.fit(model, steps=100, out=paper, overwrite=True, progress=False)
    assert (paper / "notes.txt").read_text() == "the user's notes.txt"
    assert (paper / "summary.json").read_text() != "the user's summary.json"
    assert (paper / ".slipbayes-run").exists()
