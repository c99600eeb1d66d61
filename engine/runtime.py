"""Where and how a command runs: the one device rule every command shares.

``--device auto|cpu|cuda[:N]`` — auto is CUDA when a GPU is available, else the CPU.
``--precision auto|fp32|bf16|fp16`` — the autocast dtype of the model's forward pass:

* CUDA: bf16 where the GPU supports it, else fp16 (training then scales its loss); TF32 matmuls on.
* CPU, training: bf16 only where the CPU computes it natively (AVX512-BF16 or AMX; a training step of
  the shipped model's shape measured 2.0x faster there). Elsewhere (AVX2, plain AVX-512) bf16 is
  emulated and a step measured several times slower than fp32, so auto means fp32 there.
* CPU, sampling: fp32. A sample is a few small matmuls (nothing to gain), and fp32 keeps a seed's
  motion the same on every CPU.

The model lives on the device; everything else (the sampling loop, controllers' bookkeeping, motion
arrays) lives on the CPU and tensors cross at the model's call (``Denoiser.enter``). Checkpoints stay
device-free: weights are saved from and loaded to the CPU.
"""
from __future__ import annotations

import argparse
import contextlib
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import torch

DEVICE_HELP = "where to run: auto (CUDA when a GPU is available, else the CPU), cpu, cuda or cuda:N (default: auto)"
PRECISIONS = ("auto", "fp32", "bf16", "fp16")
PRECISION_HELP = ("autocast precision of the model: auto (CUDA: bf16, or fp16 where bf16 is unsupported; CPU: fp32, "
                  "and bf16 for training only with native bf16 instructions), fp32, bf16 or fp16 (default: auto)")
_DTYPES = {"fp32": None, "bf16": torch.bfloat16, "fp16": torch.float16}


class DeviceError(ValueError):
    """A device or precision that cannot be used here (one-line message)."""


def resolve_device(spec: str | torch.device | None = "auto") -> torch.device:
    """``auto`` | ``cpu`` | ``cuda`` | ``cuda:N`` -> a usable device, or a one-line :class:`DeviceError`."""
    if isinstance(spec, torch.device):
        spec = str(spec)
    text = (spec or "auto").strip().lower()
    if text == "auto":
        # with its index: torch.cuda.set_device and DDP's device_ids need one
        return torch.device("cuda", torch.cuda.current_device()) if torch.cuda.is_available() else torch.device("cpu")
    if text == "cpu":
        return torch.device("cpu")
    match = re.fullmatch(r"cuda(?::(\d+))?", text)
    if match is None:
        raise DeviceError(f"--device {spec!r}: expected auto, cpu, cuda or cuda:N")
    if not torch.cuda.is_available():
        build = "a CPU-only build" if torch.version.cuda is None else f"a CUDA {torch.version.cuda} build"
        raise DeviceError(f"--device {text}: no CUDA GPU is available (torch {torch.__version__}, {build}); "
                          "use --device cpu or auto")
    index = int(match[1]) if match[1] is not None else torch.cuda.current_device()
    count = torch.cuda.device_count()
    if index >= count:
        raise DeviceError(f"--device {text}: this machine has {count} CUDA device(s) (cuda:0..cuda:{count - 1})")
    return torch.device("cuda", index)


@lru_cache(maxsize=1)
def cpu_flags() -> frozenset[str]:
    """The CPU's feature flags (Linux /proc/cpuinfo; empty where unreadable)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return frozenset()
    for line in text.splitlines():
        if line.startswith("flags"):
            return frozenset(line.split(":", 1)[1].split())
    return frozenset()


def cpu_native_bf16() -> bool:
    """True where the CPU computes bf16 natively: an AVX-512 build of torch and AVX512-BF16 or AMX-BF16."""
    if not torch.backends.cpu.get_cpu_capability().startswith("AVX512"):
        return False
    return bool({"avx512_bf16", "amx_bf16"} & cpu_flags())


def autocast_dtype(device: torch.device, precision: str = "auto", *, training: bool = False) -> torch.dtype | None:
    """The autocast dtype for ``precision`` on ``device`` (None = full fp32)."""
    if precision not in PRECISIONS:
        raise DeviceError(f"--precision {precision!r}: expected one of {', '.join(PRECISIONS)}")
    if precision != "auto":
        if precision == "fp16" and device.type == "cpu":
            raise DeviceError("--precision fp16 is for CUDA; on the CPU use fp32 or bf16")
        return _DTYPES[precision]
    if device.type == "cuda":
        return torch.bfloat16 if torch.cuda.is_bf16_supported() else torch.float16
    return torch.bfloat16 if training and cpu_native_bf16() else None


@dataclass(frozen=True)
class Runtime:
    """A resolved device and the autocast dtype of the model's forward pass on it."""

    device: torch.device
    dtype: torch.dtype | None = None

    @classmethod
    def create(cls, device: str | torch.device | None = "auto", precision: str = "auto", *,
               training: bool = False) -> "Runtime":
        resolved = resolve_device(device)
        if resolved.type == "cuda":
            torch.backends.cuda.matmul.allow_tf32 = True
            torch.backends.cudnn.allow_tf32 = True
        return cls(device=resolved, dtype=autocast_dtype(resolved, precision, training=training))

    @property
    def precision(self) -> str:
        return {None: "fp32", torch.bfloat16: "bf16", torch.float16: "fp16"}[self.dtype]

    def autocast(self) -> contextlib.AbstractContextManager:
        if self.dtype is None:
            return contextlib.nullcontext()
        return torch.autocast(self.device.type, dtype=self.dtype)

    def describe(self) -> str:
        name = str(self.device)
        if self.device.type == "cuda":
            name += f" ({torch.cuda.get_device_name(self.device)})"
        return f"{name}, {self.precision}"


CPU = Runtime(device=torch.device("cpu"))


def add_runtime_arguments(parser: argparse.ArgumentParser, *, precision: bool = True) -> None:
    """``--device`` (and ``--precision``) on a subcommand; read back with :func:`runtime_from_args`."""
    parser.add_argument("--device", default="auto", help=DEVICE_HELP)
    if precision:
        parser.add_argument("--precision", default="auto", choices=PRECISIONS, help=PRECISION_HELP)


def runtime_from_args(args: argparse.Namespace, *, training: bool = False) -> Runtime:
    return Runtime.create(getattr(args, "device", None) or "auto", getattr(args, "precision", None) or "auto",
                          training=training)
