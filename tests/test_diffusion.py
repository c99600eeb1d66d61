"""Schedule, the sampling loop, DDIM/DDPM and inversion against an analytic denoiser."""
from __future__ import annotations

import pytest
import torch

from engine.attention import BatchRoles
from engine.diffusion import CLEAN, CosineSchedule, ddim, ddim_invert, ddpm, final, run_loop
from engine.diffusion.sampler import land
from engine.model import Condition

SCHED = CosineSchedule()
DATA_STD = 0.5


def gaussian_denoiser(x, t, cond, *, step=0, controller=None):
    """The exact x0 posterior mean for data ~ N(0, DATA_STD^2 I)."""
    ab = SCHED.alpha_bar(t).reshape(-1, 1, 1)
    s2 = DATA_STD**2
    return ab.sqrt() * s2 / (ab * s2 + 1 - ab) * x


def cond(b=4, frames=8):
    return Condition(text_ids=torch.ones(b, 1, dtype=torch.long), text_mask=torch.ones(b, 1, dtype=torch.bool),
                     frame_mask=torch.ones(b, frames, dtype=torch.bool), use_text=torch.ones(b, dtype=torch.bool),
                     roles=BatchRoles.single("out", size=b))


def test_cosine_schedule_shape():
    ab = SCHED.alphas_cumprod
    assert ab.shape == (1000,) and (ab[1:] < ab[:-1]).all()
    assert ab[0] > 0.999 and ab[-1] < 1e-4
    assert SCHED.alpha_bar(torch.tensor(CLEAN)).item() == 1.0
    assert SCHED.timesteps(10) == [999, 899, 799, 699, 599, 499, 399, 299, 199, 99]
    assert SCHED.timesteps(1000) == list(range(999, -1, -1))
    with pytest.raises(ValueError):
        SCHED.timesteps(0)


def test_loop_yields_every_step_and_hooks_can_change_state():
    seen = []

    def hook(state):
        seen.append(state.step)
        return None

    noise = torch.randn(4, 8, 3, generator=torch.Generator().manual_seed(0))
    states = list(ddim(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=7, hooks=[hook]))
    assert [s.step for s in states] == list(range(7)) == seen
    assert states[-1].t_next == CLEAN and torch.equal(states[-1].x_prev, states[-1].x0_hat)
    for a, b in zip(states[:-1], states[1:]):
        assert torch.equal(a.x_prev, b.x_t)

    from dataclasses import replace

    def pin(state):
        return replace(state, x_prev=torch.zeros_like(state.x_prev))

    out = final(ddim(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=7, hooks=[pin]))
    assert torch.equal(out.x_prev, torch.zeros_like(noise))


def test_ddim_is_deterministic_and_ddpm_adds_noise_drawn_from_the_start():
    noise = torch.randn(4, 8, 3, generator=torch.Generator().manual_seed(0))
    a = final(ddim(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=20)).x_prev
    b = final(ddim(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=20)).x_prev
    assert torch.equal(a, b)
    c = final(ddpm(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=20)).x_prev
    d = final(ddpm(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=20)).x_prev
    assert torch.equal(c, d) and not torch.allclose(a, c, atol=1e-3)  # its noise comes from the start (SlotNoise)


@pytest.mark.parametrize("sampler", ["ddim", "ddpm"])
def test_samples_have_the_data_distribution(sampler):
    g = torch.Generator().manual_seed(3)
    noise = torch.randn(64, 32, 16, generator=g)
    if sampler == "ddim":
        out = final(ddim(gaussian_denoiser, noise, cond(64, 32), schedule=SCHED, num_steps=50)).x_prev
    else:
        out = final(ddpm(gaussian_denoiser, noise, cond(64, 32), schedule=SCHED, num_steps=200)).x_prev
    assert abs(out.std().item() - DATA_STD) < 0.03
    assert abs(out.mean().item()) < 0.02


def test_ddim_inversion_round_trip():
    x0 = DATA_STD * torch.randn(4, 8, 3, generator=torch.Generator().manual_seed(5))
    errors = {}
    for refine, landing in ((0, 0), (4, 0), (4, 4)):
        noise = final(ddim_invert(gaussian_denoiser, x0, cond(), schedule=SCHED, num_steps=50, refine=refine,
                                  landing=landing)).x_prev
        assert 0.7 < noise.std().item() < 1.3  # it really is noise-like
        back = final(ddim(gaussian_denoiser, noise, cond(), schedule=SCHED, num_steps=50)).x_prev
        errors[refine, landing] = (back - x0).abs().max().item()
    # fixed-point refinement removes the first-order error; what is left (< 1 %) is the first
    # inversion step taking the clean motion as x at the cleanest sampling timestep (t = 19) ...
    assert errors[4, 0] < 0.01 and errors[0, 0] > 5 * errors[4, 0]
    # ... which the landing solves: the rebuild's last step lands on the motion
    assert errors[4, 4] < errors[4, 0] / 10


def test_landing_solves_the_last_sampling_step_and_keeps_x0_where_the_prediction_ignores_its_input():
    x0 = DATA_STD * torch.randn(2, 8, 3, generator=torch.Generator().manual_seed(6))
    t = SCHED.timesteps(50)[-1]
    t_batch = torch.full((2,), t, dtype=torch.long)
    landed = land(gaussian_denoiser, x0, cond(2), schedule=SCHED, t=t, iterations=4)
    assert (gaussian_denoiser(landed, t_batch, cond(2)) - x0).abs().max() < 1e-5 * x0.abs().max()
    assert (gaussian_denoiser(x0, t_batch, cond(2)) - x0).abs().max() > 1e-3  # classic inversion's x_t misses it

    def constant(x, t, cond, *, step=0, controller=None):  # a prediction that ignores its input: no better iterate
        return torch.zeros_like(x)

    assert torch.equal(land(constant, x0, cond(2), schedule=SCHED, t=t, iterations=4), x0)


def test_inversion_rejects_eta():
    with pytest.raises(ValueError, match="eta"):
        list(run_loop(gaussian_denoiser, torch.zeros(1, 2, 3), cond(1, 2), schedule=SCHED, timesteps=[0, 10], eta=0.5))


def test_stochastic_steps_follow_each_slots_own_start():
    """eta > 0: a slot's path depends only on its starting noise, not on its batch or the batch's length; slots with
    the same start share every step's noise (an edit's ref and out), slots with different starts do not."""
    g = torch.Generator().manual_seed(11)
    a, b = torch.randn(1, 10, 3, generator=g), torch.randn(1, 10, 3, generator=g)

    def sample(noise, frames):
        return final(ddim(gaussian_denoiser, noise, cond(noise.shape[0], frames), schedule=SCHED, num_steps=20,
                          eta=1.0)).x_prev

    alone = sample(a, 10)
    longer = torch.cat([torch.cat([a, torch.zeros(1, 6, 3)], 1), torch.randn(1, 16, 3, generator=g)])
    batch = sample(torch.cat([b, a, a]), 10)
    assert torch.allclose(batch[1], alone[0], atol=1e-6) and torch.equal(batch[1], batch[2])
    assert torch.allclose(sample(longer, 16)[0, :10], alone[0], atol=1e-6)  # padded to 16 frames: the same path
    deterministic = final(ddim(gaussian_denoiser, a, cond(1, 10), schedule=SCHED, num_steps=20)).x_prev
    assert not torch.allclose(batch[0], alone[0]) and not torch.allclose(alone, deterministic)
    assert torch.equal(sample(a, 10), alone)  # reproducible
