"""The set network: the wheel-speed map of the ``set`` feature layout
(:mod:`nn_export.runtime.layouts`), which reads any number of obstacles up to its slots, in
any order (torch; the ``train`` extra).

Each obstacle slot (``present``, then eight inputs, the same for moving and static
obstacles) goes through one encoder, shared by all slots, together with the robot's two
wheel speeds:

    e_j = relu(W2 relu(W1 s_j + U w + b1) + b2) * present_j

The encodings are pooled by their element-wise maximum and their sum (a max sees the most
pressing obstacle, a sum how crowded it is), and a plain perceptron maps the robot's own
inputs (wheel speeds, reference) and the two pools to the wheel speeds. Empty slots are
masked out by ``present``, so the numbers they hold play no part, and permuting the slots
(moving and static alike) leaves the output unchanged up to float rounding of the sum
(tested). All operations have static shapes: the exported ONNX graph takes the flat input
row of the layout, as every gpcnav policy model does.

The standardisation is shared across slots (statistics of each element input over the
present obstacles of the training split), or the slots would not be interchangeable; the
``present`` inputs are not standardised (mean 0, scale 1), so the mask reads them as they are.
"""
from __future__ import annotations

import re

import numpy as np
import torch

__all__ = ["SetNet", "slot_structure", "set_standardisation"]

_SLOT = re.compile(r"^(mov|sta)(\d+)_(.+)$")


def slot_structure(feature_names) -> tuple[int, int, int]:
    """``(first column, slots, inputs per slot)`` of the obstacle set in ``feature_names``:
    contiguous slots named ``mov<j>_<input>`` / ``sta<j>_<input>`` with the same inputs, the
    first being ``present``; a ``ValueError`` when the names are not a set layout's."""
    names = list(feature_names)
    cols = [i for i, n in enumerate(names) if _SLOT.match(n)]
    if not cols:
        raise ValueError("the feature names hold no obstacle slots (the set network needs the set layout)")
    start, stop = cols[0], cols[-1] + 1
    if cols != list(range(start, stop)):
        raise ValueError("the obstacle slots are not contiguous")
    element = []
    for n in names[start:stop]:
        m = _SLOT.match(n)
        if element and m.group(3) == element[0]:
            break
        element.append(m.group(3))
    width = len(element)
    if not element or element[0] != "present" or (stop - start) % width:
        raise ValueError("every obstacle slot must start with 'present' and have the same inputs")
    for k in range(start, stop, width):
        if [_SLOT.match(n).group(3) for n in names[k:k + width]] != element:
            raise ValueError(f"obstacle slot at column {k} has other inputs than the first")
    return start, (stop - start) // width, width


def set_standardisation(X: np.ndarray, structure: tuple[int, int, int], mean: np.ndarray,
                        scale: np.ndarray, scale_of) -> tuple[np.ndarray, np.ndarray]:
    """``mean`` and ``scale`` (per column) with the slot columns replaced by statistics shared
    across slots: each element input's over the present obstacles of ``X``; ``present``
    itself mean 0, scale 1. ``scale_of``: the trainer's robust standard deviation."""
    start, n, w = structure
    mean, scale = mean.copy(), scale.copy()
    slots = X[:, start:start + n * w].reshape(-1, w)
    present = slots[slots[:, 0] > 0.5]
    if len(present) == 0:
        present = slots  # no obstacle at all: any shared numbers will do
    m, s = present.mean(0), scale_of(present)
    m[0], s[0] = 0.0, 1.0
    mean[start:start + n * w], scale[start:start + n * w] = np.tile(m, n), np.tile(s, n)
    return mean, scale


class SetNet(torch.nn.Module):
    """The map of the module docstring, in physical units (the interface of the plain
    perceptron: ``normalised`` on standardised inputs, ``forward`` on raw ones)."""

    def __init__(self, n_in: int, structure: tuple[int, int, int], hidden: int, n_out: int, activation,
                 layers: int = 1, encoder_width: int = 64):
        super().__init__()
        start, n, w = (int(v) for v in structure)
        if start < 2 or start + n * w > n_in:
            raise ValueError(f"obstacle slots {structure} do not fit {n_in} inputs after the two wheel speeds")
        self.start, self.n_slots, self.width = start, n, w
        E = int(encoder_width)
        self.enc_slot = torch.nn.Linear(w - 1, E)
        self.enc_wheels = torch.nn.Linear(2, E, bias=False)
        self.enc_out = torch.nn.Linear(E, E)
        n_ego = n_in - n * w
        self.hidden = torch.nn.Linear(n_ego + 2 * E, hidden)
        self.act = activation()
        self.deeper = torch.nn.ModuleList(torch.nn.Linear(hidden, hidden) for _ in range(int(layers) - 1))
        self.out = torch.nn.Linear(hidden, n_out)
        for name, size in (("x_mean", n_in), ("x_scale", n_in), ("y_mean", n_out), ("y_scale", n_out)):
            self.register_buffer(name, torch.zeros(size))
        self.register_buffer("y_mix", torch.eye(n_out))

    def pooled(self, xn):
        """The robot's own inputs and the two pools of the obstacle encodings, (batch, n_ego + 2 E)."""
        s, n, w = self.start, self.n_slots, self.width
        stop = s + n * w
        slots = xn[:, s:stop].reshape(-1, n, w)
        mask = slots[:, :, :1]
        first = self.enc_slot(slots[:, :, 1:]) + self.enc_wheels(xn[:, :2]).unsqueeze(1)
        e = torch.relu(self.enc_out(torch.relu(first))) * mask
        return torch.cat([xn[:, :s], xn[:, stop:], e.max(dim=1).values, e.sum(dim=1)], dim=1)

    def normalised(self, xn):
        h = self.act(self.hidden(self.pooled(xn)))
        for lin in self.deeper:
            h = self.act(lin(h))
        return self.out(h)

    def forward(self, x):
        return (self.normalised((x - self.x_mean) / self.x_scale) * self.y_scale + self.y_mean) @ self.y_mix.T
