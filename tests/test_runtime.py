"""The one device rule: --device auto|cpu|cuda[:N], precision by device and CPU, clear refusals, device-free
checkpoints. CUDA itself is exercised only where a GPU is at hand (`moattn bench --train --device cuda`)."""
from __future__ import annotations

import pytest
import torch

from engine import runtime as rt
from engine.cli import main
from engine.runtime import DeviceError, Runtime, autocast_dtype, resolve_device

CUDA = torch.cuda.is_available()


def test_auto_picks_cuda_only_when_a_gpu_is_available():
    assert resolve_device("auto").type == ("cuda" if CUDA else "cpu")
    assert resolve_device("cpu") == torch.device("cpu")
    assert resolve_device(" CPU ") == torch.device("cpu")


@pytest.mark.parametrize("spec", ["gpu", "cuda:x", "cuda:-1", "mps0", ""])
def test_unknown_device_names_are_refused_in_one_line(spec):
    if spec == "":
        assert resolve_device(spec) == resolve_device("auto")  # empty means the default
        return
    with pytest.raises(DeviceError, match="expected auto, cpu, cuda or cuda:N"):
        resolve_device(spec)


def test_cuda_asked_for_and_absent_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(DeviceError, match="no CUDA GPU is available.*use --device cpu or auto"):
        resolve_device("cuda")
    with pytest.raises(DeviceError, match="no CUDA GPU"):
        resolve_device("cuda:1")


def test_a_cuda_index_past_the_last_gpu_is_refused(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 2)
    monkeypatch.setattr(torch.cuda, "current_device", lambda: 0)
    assert resolve_device("cuda:1") == torch.device("cuda", 1)
    # always with an index: torch.cuda.set_device and DDP's device_ids refuse a bare "cuda"
    assert resolve_device("cuda") == torch.device("cuda", 0) and resolve_device("auto") == torch.device("cuda", 0)
    with pytest.raises(DeviceError, match="has 2 CUDA device"):
        resolve_device("cuda:2")


def test_cpu_bf16_only_where_the_cpu_has_it_natively(monkeypatch):
    cpu = torch.device("cpu")
    # sampling on the CPU is fp32 everywhere (the same motion for a seed on every CPU)
    assert autocast_dtype(cpu, "auto") is None
    rt.cpu_flags.cache_clear()
    monkeypatch.setattr(rt, "cpu_flags", lambda: frozenset({"avx2", "avx512f"}))
    monkeypatch.setattr(torch.backends.cpu, "get_cpu_capability", lambda: "AVX512")
    assert not rt.cpu_native_bf16()
    assert autocast_dtype(cpu, "auto", training=True) is None  # emulated bf16 is slower: fp32
    monkeypatch.setattr(rt, "cpu_flags", lambda: frozenset({"avx512f", "avx512_bf16"}))
    assert rt.cpu_native_bf16()
    assert autocast_dtype(cpu, "auto", training=True) is torch.bfloat16
    monkeypatch.setattr(torch.backends.cpu, "get_cpu_capability", lambda: "AVX2")  # an AVX2 build of the kernels
    assert autocast_dtype(cpu, "auto", training=True) is None
    # asked for explicitly, the user gets it (bf16), or a clear refusal (fp16 on the CPU)
    assert autocast_dtype(cpu, "bf16") is torch.bfloat16 and autocast_dtype(cpu, "fp32") is None
    with pytest.raises(DeviceError, match="fp16 is for CUDA"):
        autocast_dtype(cpu, "fp16")
    with pytest.raises(DeviceError, match="expected one of"):
        autocast_dtype(cpu, "int8")


def test_cuda_precision_prefers_bf16(monkeypatch):
    cuda = torch.device("cuda", 0)
    monkeypatch.setattr(torch.cuda, "is_bf16_supported", lambda *a, **k: True)
    assert autocast_dtype(cuda, "auto") is torch.bfloat16
    monkeypatch.setattr(torch.cuda, "is_bf16_supported", lambda *a, **k: False)
    assert autocast_dtype(cuda, "auto", training=True) is torch.float16


@pytest.mark.parametrize("command", [
    ["generate", "a person walks", "--out", "{tmp}/x.npy"],
    ["edit", "emphasize", "a person jumps", "--word", "jumps", "--out", "{tmp}/x.npy"],
    ["transfer", "--leader", "a person walks", "--follower", "a person runs", "--out", "{tmp}/x.npy"],
    ["analyze-qk", "--leader", "a person walks", "--follower", "a person runs", "--out", "{tmp}/qk"],
    ["control", "--prompt", "a person walks", "--out", "{tmp}/x.npy"],
    ["invert", "{tmp}/none.npy"],
    ["compose", "a person walks:2", "--out", "{tmp}/x.npy"],
    ["duet", "two people shake hands", "--out", "{tmp}/x.npy"],
    ["train", "--out", "{tmp}/run", "--steps", "1"],
    ["eval", "--quick"],
    ["evaluator", "--out", "{tmp}/run"],
    ["bench", "--adherence"],
    ["bench", "--train"],
    ["serve"],
])
def test_every_command_refuses_an_absent_gpu_in_one_line(command, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    argv = [part.replace("{tmp}", str(tmp_path)) for part in command] + ["--device", "cuda"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no CUDA GPU is available" in err, err
    assert not (tmp_path / "run").exists()  # refused before anything was written


def test_the_model_loads_onto_the_runtime_and_the_files_stay_device_free(tmp_path):
    from engine.checkpoint import load_model
    from engine.paths import MODEL_DIR

    loaded = load_model(MODEL_DIR, runtime=Runtime.create("cpu"))
    assert loaded.model.device == torch.device("cpu") and loaded.runtime.precision == "fp32"
    weights = torch.load(MODEL_DIR / "weights.pt", weights_only=True)
    assert all(v.device.type == "cpu" for v in weights.values())


def test_autocast_on_the_model_changes_precision_not_the_interface():
    """A model with bf16 autocast takes and returns the caller's fp32 tensors; fp32 (None) is bit-identical
    to calling with no runtime at all."""
    from engine.attention.context import BatchRoles
    from engine.model.denoiser import Condition, Denoiser, ModelConfig

    torch.manual_seed(0)
    model = Denoiser(ModelConfig(width=32, layers=2, heads=2, text_layers=1, dropout=0.0, vocab_size=16)).eval()
    x, t = torch.randn(2, 24, 263), torch.tensor([10, 500])
    cond = Condition(text_ids=torch.randint(1, 10, (2, 5)), text_mask=torch.ones(2, 5, dtype=torch.bool),
                     frame_mask=torch.ones(2, 24, dtype=torch.bool), use_text=torch.ones(2, dtype=torch.bool),
                     roles=BatchRoles.single("out", size=2))
    with torch.no_grad():
        plain = model(x, t, cond)
        model.autocast_dtype = torch.bfloat16
        low = model(x, t, cond)
        model.autocast_dtype = None
        again = model(x, t, cond)
    assert torch.equal(plain, again)
    assert low.dtype == torch.float32 and low.shape == plain.shape
    assert 0 < (low - plain).abs().max() < 0.1 * plain.abs().max()
