"""Issue 23, the laboratory's commands: requests beyond what they can hold refused before any work with the limit
in the message, options refused before the work runs rather than after, an explicitly requested scenario whose
data are missing an error, and messages that name the file."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from omegahat.cli import main
from omegahat.lab.campaigns import config as campaign_config
from omegahat.lab.cli import compare, control, paper

CAMPAIGN = Path(__file__).resolve().parents[1] / "examples" / "campaign.toml"


def refused(capsys, argv, *, parse: bool = False) -> tuple[str, float]:
    """Run ``omegahat ARGV`` expecting exit 2; ``(standard error, seconds)``. ``parse``: refused by argparse."""
    start = time.perf_counter()
    if parse:
        with pytest.raises(SystemExit) as exc:
            main([str(a) for a in argv])
        code = exc.value.code
    else:
        code = main([str(a) for a in argv])
    seconds = time.perf_counter() - start
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    return err, seconds


def test_a_campaign_of_1e12_runs_is_refused_within_seconds(capsys, tmp_path):
    err, seconds = refused(capsys, ["montecarlo", CAMPAIGN, "--runs", "1000000000000", "--out", tmp_path / "o"])
    # 1e12 runs x 3 gain sets x 8 bytes x (401 output times + 11 numbers) = 9.888e15
    assert (
        "Campaign: 1,000,000,000,000 runs x 3 gain sets would hold 9.89e+15 bytes of results (401 output times" in err
    )
    assert f"omegahat holds at most {campaign_config.MAX_RESULT_BYTES:.3g} bytes (4 GiB)" in err
    assert seconds < 10 and not (tmp_path / "o").exists()


def test_the_campaign_limit_is_its_results_memory():
    c = campaign_config.load_campaign(CAMPAIGN)
    per_run = len(c.gains) * 8 * (len(c.t_out) + 11)  # rho at every output time, and 11 numbers (GainSetResult)
    assert c.result_bytes == c.runs * per_run
    most = campaign_config.MAX_RESULT_BYTES // per_run
    assert campaign_config.replace(c, runs=most).runs == most
    with pytest.raises(ValueError, match="would hold"):
        campaign_config.replace(c, runs=most + 1)
    with pytest.raises(ValueError, match="would hold"):  # the output grid counts too
        campaign_config.replace(c, runs=1, horizon=1e9, dt_out=1e-6)


@pytest.mark.parametrize("duration", ["inf", "nan", "-1", "0"])
def test_compare_duration_must_be_a_positive_number(capsys, duration):
    err, _ = refused(capsys, ["compare", "--duration", duration], parse=True)
    assert f"expected a positive number, got '{duration}'" in err


def test_compare_duration_beyond_the_sample_limit(capsys, tmp_path):
    err, seconds = refused(capsys, ["compare", "--duration", "1e9", "--scenario", "paper", "--out", tmp_path / "o"])
    assert "--duration 1e+09 s is 1e+11 samples of scenario paper (100 Hz); omegahat compare simulates at most" in err
    assert f"{compare.MAX_SAMPLES:,}" in err and seconds < 10 and not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("1e12", f"1e12 is more than omegahat takes here: at most {compare.MAX_ROBUSTNESS_RUNS:,}"),
        ("-3", "expected an integer >= 0, got '-3'"),
        ("2.5", "expected an integer, got '2.5'"),
    ],
)
def test_compare_robustness_runs_refused_before_the_work(capsys, value, message):
    err, seconds = refused(capsys, ["compare", "--robustness-runs", value], parse=True)
    assert message in err and seconds < 10


def test_paper_dt_beyond_the_sample_limit(capsys, tmp_path):
    err, seconds = refused(capsys, ["paper", "--dt", "1e-12", "--out", tmp_path / "o"])
    assert "--horizon 10 with --dt 1e-12 is 1e+13 output samples; omegahat paper writes at most" in err
    assert f"{paper.MAX_SAMPLES:,}" in err and seconds < 10 and not (tmp_path / "o").exists()
    err, _ = refused(capsys, ["paper", "--horizon", "1e7", "--dt", "10", "--out", tmp_path / "o"])
    assert "--horizon 1e+07 s is beyond what the integrator reaches in 10,000,000 steps of at most 0.05 s" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--runs", "1e12"], f"1e12 is more than omegahat takes here: at most {control.MAX_RUNS:,}"),
        (["--seed", "-5"], "expected an integer >= 0, got '-5'"),
    ],
)
def test_control_runs_and_seed_refused_before_the_work(capsys, argv, message):
    err, seconds = refused(capsys, ["control", *argv], parse=True)
    assert message in err and seconds < 10


@pytest.mark.parametrize("command", ["montecarlo", "compare", "paper", "control"])
def test_an_output_folder_that_is_a_file_is_refused_before_the_work(capsys, tmp_path, command):
    existing = tmp_path / "results"
    existing.write_text("keep me")
    argv = [command, *([CAMPAIGN, "--runs", "3"] if command == "montecarlo" else []), "--out", existing]
    err, seconds = refused(capsys, argv)
    assert f"--out {existing} is a file, not a folder" in err
    assert seconds < 10 and existing.read_text() == "keep me"


def test_a_requested_scenario_without_its_data_is_an_error(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("OMEGAHAT_BROAD_DIR", str(tmp_path / "nowhere"))
    err, seconds = refused(capsys, ["compare", "--scenario", "broad-01", "--out", tmp_path / "o"])
    assert "--scenario broad-01: data directory" in err and "not found" in err and "OMEGAHAT_BROAD_DIR" in err
    assert seconds < 10 and not (tmp_path / "o").exists()


def test_a_campaign_file_of_random_bytes_is_named(capsys, tmp_path):
    bad = tmp_path / "random.toml"
    bad.write_bytes(os.urandom(64) + b"\xff")
    err, _ = refused(capsys, ["montecarlo", bad, "--out", tmp_path / "o"])
    assert f"{bad}: not a TOML file (not UTF-8 text: byte" in err
