"""`moattn bench --sampling`: a quick default (DDIM 10/20/50, no DDPM-1000 row), the slow rows opt-in."""
from __future__ import annotations

from dataclasses import replace

import pytest

from engine.evaluation.bench_sampling import (
    DEFAULT_SETTINGS,
    SETTINGS,
    SamplingBenchConfig,
    bench_sampling,
    format_table,
    sampling_steps,
)
from tests.test_eval_run import tiny_evaluator, tiny_model  # noqa: F401  (fixtures)


def test_the_ddpm_row_is_opt_in():
    assert DEFAULT_SETTINGS == ("10", "20", "50")
    for config in (SamplingBenchConfig(), SamplingBenchConfig.quick()):
        assert list(config.settings) == ["10", "20", "50"]
        assert all(sampler == "ddim" for sampler, _ in config.settings.values())
    assert list(replace(SamplingBenchConfig(), ddpm=True).settings) == list(SETTINGS)
    assert list(SamplingBenchConfig.full().settings) == list(SETTINGS)


def test_the_default_run_is_a_small_fraction_of_the_full_one():
    """The default must stay a few minutes on 2 cores: counted in sampling steps, it is under a tenth of the
    thorough run (which took over half an hour), and the DDPM row alone would be ten times the default's work."""
    default, quick, full = (sampling_steps(c) for c in (SamplingBenchConfig(), SamplingBenchConfig.quick(),
                                                         SamplingBenchConfig.full()))
    assert default == {"single": 1180, "batched": 80}
    assert full == {"single": 20_000, "batched": 2160}
    assert default["single"] < full["single"] / 10 and default["batched"] < full["batched"] / 10
    assert quick["single"] < default["single"]
    with_ddpm = sampling_steps(replace(SamplingBenchConfig(), ddpm=True))
    assert with_ddpm["single"] > 9 * default["single"]


def test_tiny_end_to_end_has_no_ddpm_row(tiny_model, tiny_evaluator):  # noqa: F811
    config = SamplingBenchConfig(seconds=1.0, repeats=1, prompts=2, fid_samples=2, validation_motions=10)
    result = bench_sampling(tiny_model, tiny_evaluator, config, prompts=["a person jumps", "a person walks forward"])
    assert list(result["seconds"]) == list(result["fid"]) == list(result["adherence"]) == ["10", "20", "50"]
    assert result["settings"]["rows"] == ["10", "20", "50"]
    table = format_table(result)
    assert any(line.startswith("ddim 50") for line in table.splitlines())
    assert not any(line.startswith("ddpm 1000") for line in table.splitlines())
    assert "add --ddpm" in table and "ddpm1000 once" not in table


@pytest.mark.parametrize("argv,message", [
    (["--inversion", "--ddpm"], "--ddpm and --full go with --sampling"),
    (["--adherence", "--full"], "--ddpm and --full go with --sampling"),
    (["--sampling", "--full", "--quick"], "--full and --quick are opposites"),
])
def test_sampling_flags_are_checked_before_any_model_loads(capsys, argv, message):
    from engine.cli import main

    assert main(["bench", *argv, "--model", "/nonexistent"]) == 2
    assert message in capsys.readouterr().err
