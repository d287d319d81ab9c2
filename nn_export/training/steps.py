"""The optimisation steps of :class:`~nn_export.training.train.WheelSpeedMLP` (torch): the
standardised splits and their error, one L-BFGS step, one Adam epoch, the robust scale."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["Splits", "validation_count", "weighted_loss", "lbfgs_step", "adam_epoch", "robust_scale", "copy_state"]

_STD_FLOOR = 1e-9  # below this a feature is constant (e.g. an absent-obstacle code): its scale is 1,
# as in scikit-learn's StandardScaler, so that it neither divides by zero nor magnifies float32 rounding


@dataclass(frozen=True)
class Splits:
    """The standardised training (``xt``, ``yt``) and validation (``xv``, ``yv``) splits,
    and what maps the network's errors back to wheel speeds."""

    xt: torch.Tensor
    yt: torch.Tensor
    xv: torch.Tensor
    yv: torch.Tensor
    y_scale: torch.Tensor
    mix: torch.Tensor
    wt: torch.Tensor | None = None
    """Per-sample loss weights of the training split (None: all 1)."""
    wv: torch.Tensor | None = None
    """... of the validation split."""

    def mse(self, net: torch.nn.Module, xn: torch.Tensor, yn: torch.Tensor, w: torch.Tensor | None = None) -> float:
        """Mean squared wheel-speed error over samples (weighted by ``w`` when given) and
        both wheels, (m/s)^2."""
        with torch.no_grad():
            return float(_mean((((net.normalised(xn) - yn) * self.y_scale) @ self.mix.T) ** 2, w))


def validation_count(fraction: float, n: int, what: str) -> int:
    """How many of ``n`` samples or situations go to the validation split; a fraction that leaves
    none to train on is refused (--validation-fraction 0.999 trained on nothing, then "diverged")."""
    n_val = max(1, int(round(fraction * n)))
    if n_val >= n:
        raise ValueError(f"validation fraction {fraction} of {n} {what} leaves none to train on")
    return n_val


def weighted_loss(pred: torch.Tensor, target: torch.Tensor, w: torch.Tensor | None) -> torch.Tensor:
    """The training loss: the mean squared error, each sample weighted by ``w`` (None: plain)."""
    return _mean((pred - target) ** 2, w)


def _mean(sq: torch.Tensor, w: torch.Tensor | None) -> torch.Tensor:
    """The mean of ``sq`` (samples, outputs), each sample weighted by ``w`` (None: plain)."""
    return sq.mean() if w is None else (sq.mean(1) * w).sum() / w.sum()


def lbfgs_step(opt, net: torch.nn.Module, closure) -> int:
    """One L-BFGS step; if it did not move at all, a restart from steepest descent (returns 1)."""
    before = [q.detach().clone() for q in net.parameters()]
    opt.step(closure)
    if all(torch.equal(a, b) for a, b in zip(before, net.parameters())):
        opt.state.clear()
        opt.step(closure)
        return 1
    return 0


def adam_epoch(opt, net: torch.nn.Module, xt: torch.Tensor, yt: torch.Tensor, batch_size: int, gen: torch.Generator,
               wt: torch.Tensor | None = None) -> None:
    """One pass of Adam over the training split in a shuffled order (``wt``: sample weights)."""
    order = torch.randperm(len(xt), generator=gen)
    for start in range(0, len(xt), batch_size):
        b = order[start:start + batch_size]
        opt.zero_grad(set_to_none=True)
        loss = weighted_loss(net.normalised(xt[b]), yt[b], None if wt is None else wt[b])
        loss.backward()
        opt.step()


def robust_scale(A: np.ndarray) -> np.ndarray:
    sd = A.std(0)
    return np.where(sd > _STD_FLOOR * np.maximum(1.0, np.abs(A.mean(0))), sd, 1.0)


def copy_state(net):
    return {k: v.detach().clone() for k, v in net.state_dict().items()}


def checked_arrays(X, Y, feature_names, label_names) -> tuple[np.ndarray, np.ndarray]:
    """``X`` and ``Y`` as float64 arrays, refused (ValueError) when they cannot be learned."""
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    if X.ndim != 2 or Y.ndim != 2:
        raise ValueError(f"X and Y must be 2-D, got shapes {X.shape} and {Y.shape}")
    if len(X) != len(Y):
        raise ValueError(f"X has {len(X)} rows but Y has {len(Y)}")
    if len(X) < 10:
        raise ValueError(f"need at least 10 samples to train and validate, got {len(X)}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
        raise ValueError("X and Y must be finite")
    if feature_names is not None and len(feature_names) != X.shape[1]:
        raise ValueError(f"{len(feature_names)} feature names for {X.shape[1]} features")
    if label_names is not None and len(label_names) != Y.shape[1]:
        raise ValueError(f"{len(label_names)} label names for {Y.shape[1]} labels")
    return X, Y
