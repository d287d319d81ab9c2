"""Training the wheel-speed network on GPC labels (torch; the ``train`` extra).

:class:`WheelSpeedMLP` follows the estimator conventions: ``__init__`` only stores
hyper-parameters, :meth:`WheelSpeedMLP.fit` validates the arrays and learns, and everything
learned ends in ``_``. The default is the paper's network: one hidden layer of 35 tanh
units and 2 outputs (right and left wheel speed, m/s). Inputs and outputs are standardised
with statistics of the training split only; a seeded held-out split drives early stopping,
and the best weights seen on it are kept.

The training curve (the paper's Fig. 6) is recorded once per iteration (L-BFGS, the default) or
epoch (Adam): the mean squared error of the right and left wheel speed, (m/s)^2, on the whole
training split and on the validation split. The paper plots the summed squared error over its N
patterns; the mean is that sum divided by N (both N are stored), so runs of different sizes compare.

A fitted model is saved to a folder (``save``/``load``): ``weights.npz`` (plain arrays, no pickle),
``model.json`` (hyper-parameters, normalisation, feature layout, provenance, validation error),
``training_curve.json`` and ``training_curve.png``.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from casadi_gpc.io import UNREADABLE_NPZ

from ..runtime.layouts import WHEEL_INPUTS
from .curve import save_curve_figure
from .set_net import SetNet, set_standardisation, slot_structure
from .warm_start import start_from
from .steps import (Splits, adam_epoch, checked_arrays as _checked_arrays, copy_state, lbfgs_step, robust_scale,
                    validation_count, weighted_loss)

__all__ = ["WheelSpeedMLP", "MODEL_FORMAT", "save_curve_figure", "current_wheels", "wheel_selection"]

MODEL_FORMAT = "gpcnav-mlp/1"
_ACTIVATIONS = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU, "softsign": torch.nn.Softsign}
LBFGS_ITERATIONS_PER_STEP = 10


def wheel_selection(n_in: int, n_out: int, dtype=torch.float64) -> torch.Tensor:
    """``(n_in, n_out)`` matrix of zeros and ones: ``x @ S`` is the current wheel speeds (the
    first two inputs of ``x``), once per (right, left) pair of ``n_out`` outputs, exactly
    (each column holds one 1). A matrix, not slicing and tiling: in the exported graph it is
    one MatMul, where the traced slice-and-repeat was 25 nodes and 19 % of the call."""
    S = torch.zeros(n_in, n_out, dtype=dtype)
    S[0, 0::2] = 1.0
    S[1, 1::2] = 1.0
    return S


def current_wheels(x: torch.Tensor, n_out: int) -> torch.Tensor:
    """What a ``relative`` network's output is added to (:func:`wheel_selection`)."""
    return x @ wheel_selection(x.shape[1], n_out, x.dtype)


class _Net(torch.nn.Module):
    """x -> (x - mu)/sd -> hidden -> (output * u_sd + u_mu) @ mix^T: the whole map in physical
    units. ``mix`` maps the learned output basis u to the wheel speeds (identity, or
    [[1, 1], [1, -1]] for u = (mean speed, half difference))."""

    def __init__(self, n_in: int, hidden: int, n_out: int, activation: str, layers: int = 1):
        super().__init__()
        self.hidden = torch.nn.Linear(n_in, hidden)
        self.act = _ACTIVATIONS[activation]()
        # further hidden layers of the same width (layers > 1; the paper's net has one)
        self.deeper = torch.nn.ModuleList(torch.nn.Linear(hidden, hidden) for _ in range(int(layers) - 1))
        self.out = torch.nn.Linear(hidden, n_out)
        for name in ("x_mean", "x_scale", "y_mean", "y_scale"):
            self.register_buffer(name, torch.zeros(n_out if name[0] == "y" else n_in))
        self.register_buffer("y_mix", torch.eye(n_out))

    def normalised(self, xn):
        h = self.act(self.hidden(xn))
        for lin in self.deeper:
            h = self.act(lin(h))
        return self.out(h)

    def forward(self, x):
        return (self.normalised((x - self.x_mean) / self.x_scale) * self.y_scale + self.y_mean) @ self.y_mix.T


class WheelSpeedMLP:
    """One-hidden-layer perceptron from features to the two wheel speeds.

    Parameters
    ----------
    hidden : int
        Hidden units per hidden layer (paper: 35).
    layers : int
        Hidden layers (paper: 1), each of ``hidden`` units and the same non-linearity.
    activation : {"tanh", "relu", "softsign"}
        Hidden non-linearity (paper: a sigmoid-type unit; tanh is its zero-centred form).
    output_basis : {"speed_turn", "wheels"}
        What the network learns, each output standardised on its own: ``speed_turn``
        (default) the mean speed (vr + vl)/2 and the half difference (vr - vl)/2, mapped back
        to the wheels by a fixed matrix in the graph; ``wheels`` the two wheel speeds. The
        turning part of a swerve is small beside the speed; standardised alone it weighs as
        much as the speed in the loss, and the network learns the swerves (measured:
        docs/nn-training.md).
    optimizer : {"lbfgs", "adam"}
        ``lbfgs`` (default): full-batch L-BFGS with a strong-Wolfe line search, 10
        iterations per step and per curve point (a 17-35-2 net has ~700 weights: second-order steps reach
        a lower error in seconds); ``adam``: mini-batch Adam, one epoch per curve point.
    max_epochs : int
        Upper bound on steps (L-BFGS, 10 iterations each) or passes over the training split (Adam).
    batch_size : int
        Mini-batch size of Adam (unused by L-BFGS).
    learning_rate : float
        Initial Adam step, divided by 3 when the validation error has not improved for
        ``patience // 4`` epochs (L-BFGS uses its line search).
    weight_decay : float
        L2 penalty of Adam.
    validation_fraction : float
        Share of the samples (or of the groups, see ``fit``) held out for validation.
    patience : int
        Stop after this many epochs without a new best validation error.
    random_state : int
        Seeds the split, the initial weights and the batch order: equal seeds give equal
        models on this machine.
    architecture : {"mlp", "set"}
        ``mlp`` (default): the perceptron on the whole input row; ``set``: the obstacle slots
        of the ``set`` layout encoded alike and pooled (:mod:`nn_export.training.set_net`),
        the perceptron on the robot's inputs and the pools (``fit`` needs ``feature_names``).
    encoder_width : int
        Units of the set network's obstacle encoder (``set`` only).
    relative : bool
        Learn the change from the robot's current wheel speeds (the first two inputs) instead
        of the wheel speeds themselves; the map adds them back (:func:`current_wheels`), in
        the exported graph too. Most labels lie close to the current speeds (the GPC's cost
        charges every increment), so an absolute network spends its fit on reproducing them;
        a relative one fits the increments the GPC decides, as the GPC's own decision
        variables are (measured: docs/nn-crowds.md, "The relative target").
    """

    def __init__(self, hidden: int = 35, activation: str = "tanh", output_basis: str = "speed_turn",
                 optimizer: str = "lbfgs", max_epochs: int = 400, layers: int = 1,
                 batch_size: int = 1024, learning_rate: float = 3e-3, weight_decay: float = 0.0,
                 validation_fraction: float = 0.15, patience: int = 40, random_state: int = 0,
                 architecture: str = "mlp", encoder_width: int = 64, relative: bool = False):
        self.hidden = hidden
        self.layers = layers
        self.activation = activation
        self.optimizer = optimizer
        self.output_basis = output_basis
        self.max_epochs = max_epochs
        self.batch_size = batch_size
        self.learning_rate = learning_rate
        self.weight_decay = weight_decay
        self.validation_fraction = validation_fraction
        self.patience = patience
        self.random_state = random_state
        self.architecture = architecture
        self.encoder_width = encoder_width
        self.relative = relative

    # --- hyper-parameters ------------------------------------------------------------
    def get_params(self) -> dict:
        params = {k: getattr(self, k) for k in ("hidden", "layers", "activation", "output_basis", "optimizer", "max_epochs", "batch_size", "learning_rate",
                                                "weight_decay", "validation_fraction", "patience", "random_state")}
        if self.architecture != "mlp":  # only then: a perceptron's files stay what they were
            params.update(architecture=self.architecture, encoder_width=self.encoder_width)
        if self.relative:  # likewise
            params.update(relative=True)
        return params

    def _check_params(self) -> None:
        if not (isinstance(self.hidden, int) and self.hidden >= 1):
            raise ValueError(f"hidden must be a positive integer, got {self.hidden!r}")
        if not (isinstance(self.layers, int) and 1 <= self.layers <= 4):
            raise ValueError(f"layers must be an integer from 1 to 4, got {self.layers!r}")
        if self.activation not in _ACTIVATIONS:
            raise ValueError(f"activation must be one of {', '.join(_ACTIVATIONS)}, got {self.activation!r}")
        if self.output_basis not in ("speed_turn", "wheels"):
            raise ValueError(f"output_basis must be 'speed_turn' or 'wheels', got {self.output_basis!r}")
        if self.architecture not in ("mlp", "set"):
            raise ValueError(f"architecture must be 'mlp' or 'set', got {self.architecture!r}")
        if not (isinstance(self.encoder_width, int) and self.encoder_width >= 1):
            raise ValueError(f"encoder_width must be a positive integer, got {self.encoder_width!r}")
        if self.optimizer not in ("lbfgs", "adam"):
            raise ValueError(f"optimizer must be 'lbfgs' or 'adam', got {self.optimizer!r}")
        if not (0.0 < self.validation_fraction < 1.0):
            raise ValueError(f"validation_fraction must be in (0, 1), got {self.validation_fraction}")
        for name in ("max_epochs", "batch_size", "patience"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if not (self.learning_rate > 0 and 0 <= self.weight_decay < math.inf):
            raise ValueError(f"learning_rate must be positive and weight_decay finite and not negative, got "
                             f"{self.learning_rate} and {self.weight_decay}")

    # --- learning --------------------------------------------------------------------
    def fit(self, X, Y, groups=None, feature_names=None, label_names=None, progress=None,
            sample_weight=None, init_state=None) -> "WheelSpeedMLP":
        """Learn the map ``X -> Y``.

        Parameters
        ----------
        X : array (n, n_features)
            Features, all finite.
        Y : array (n, 2) or (n, 2 H)
            Labels: right and left wheel speed, m/s; or a plan, the pairs of its H steps.
        groups : array (n,), optional
            Samples with the same group id go to the same side of the validation split
            (a situation and its mirror image must, or the validation error leaks).
        feature_names, label_names : sequence of str, optional
            Stored with the model and checked against its input and output sizes.
        progress : callable(epoch, train_mse, val_mse), optional
            Called after each epoch (the CLI's progress bar).
        sample_weight : array (n,), optional
            Positive weights of the samples in the loss and in the validation error that
            picks the best epoch (:mod:`nn_export.training.weights`); the errors the model
            reports (``train_mse_``, ``validation_mse_``) stay unweighted.
        init_state : dict, optional
            Start from these weights, standardisation and output basis (a network of this
            architecture's state, as :func:`nn_export.training.warm_start.read_set_network` reads it
            from an exported file) instead of fresh ones: the network trained further. Epoch 0 of
            the curve is the network as given.
        """
        self._check_params()
        X, Y = _checked_arrays(X, Y, feature_names, label_names)
        if sample_weight is not None:
            sample_weight = np.asarray(sample_weight, dtype=float)
            finite_positive = np.all(np.isfinite(sample_weight)) and np.all(sample_weight > 0)
            if sample_weight.shape != (len(X),) or not finite_positive:
                raise ValueError(f"sample_weight must be {len(X)} positive finite numbers")
        rng = np.random.default_rng(self.random_state)
        train_idx, val_idx = self._split(len(X), groups, rng)
        torch.set_num_threads(1)  # a small net: threads only add nondeterminism and contention
        torch.manual_seed(self.random_state)
        gen = torch.Generator().manual_seed(self.random_state)
        net, data = self._standardised(X, Y, train_idx, val_idx, feature_names, init_state)
        if sample_weight is not None:
            w = torch.from_numpy(sample_weight)
            data = replace(data, wt=w[train_idx], wv=w[val_idx])
        t0 = time.perf_counter()
        curve, best_state = self._train(net, data, gen, progress)
        net.load_state_dict(best_state)
        net.eval()
        self._keep(net, data, X, Y, train_idx, val_idx, feature_names, label_names)
        restarts = curve.pop("lbfgs_restarts")
        self.curve_ = {**curve, "optimizer": self.optimizer, "n_train": int(len(train_idx)),
                       "n_validation": int(len(val_idx)), "best_epoch": self.best_epoch_,
                       "stop_reason": self.stop_reason_, "lbfgs_restarts": restarts,
                       "train_time_s": time.perf_counter() - t0, "units": "(m/s)^2, mean over samples and wheels"}
        return self

    def _standardised(self, X: np.ndarray, Y: np.ndarray, train_idx, val_idx, feature_names=None,
                      init_state=None) -> tuple[_Net, "Splits"]:
        """The network with the training split's standardisation in its buffers (or ``init_state``'s
        weights and standardisation), and both splits standardised (in the learned output basis)."""
        x_mean, x_scale = X[train_idx].mean(0), robust_scale(X[train_idx])
        if self.architecture == "set":
            if feature_names is None:
                raise ValueError("the set architecture needs the feature names (to find the obstacle slots)")
            structure = slot_structure(feature_names)
            x_mean, x_scale = set_standardisation(X[train_idx], structure, x_mean, x_scale, robust_scale)
        if (self.output_basis == "speed_turn" or self.relative) and Y.shape[1] % 2:
            raise ValueError(f"output_basis 'speed_turn' and relative need wheel pairs (an even number of outputs), "
                             f"Y has {Y.shape[1]}")
        if self.relative:
            if feature_names is not None and tuple(feature_names[:2]) != WHEEL_INPUTS:
                raise ValueError(f"relative needs the current wheel speeds {WHEEL_INPUTS} as the first two "
                                 f"features, got {tuple(feature_names[:2])}")
            Y = Y - current_wheels(torch.from_numpy(X), Y.shape[1]).numpy()
        # speed_turn: (mean speed, half difference) of each (right, left) pair: one command or a plan's steps
        mix = (np.kron(np.eye(Y.shape[1] // 2), [[1.0, 1.0], [1.0, -1.0]]) if self.output_basis == "speed_turn"
               else np.eye(Y.shape[1]))
        U = Y @ np.linalg.inv(mix).T  # the learned basis: wheels = U @ mix^T
        y_mean, y_scale = U[train_idx].mean(0), robust_scale(U[train_idx])
        net = self._new_net(X.shape[1], Y.shape[1], feature_names)
        if init_state is not None:
            x_mean, x_scale, y_mean, y_scale = start_from(net, init_state, mix)
        with torch.no_grad():
            net.y_mix.copy_(torch.from_numpy(mix))
            net.x_mean.copy_(torch.from_numpy(x_mean))
            net.x_scale.copy_(torch.from_numpy(x_scale))
            net.y_mean.copy_(torch.from_numpy(y_mean))
            net.y_scale.copy_(torch.from_numpy(y_scale))
        Xn = torch.from_numpy((X - x_mean) / x_scale)
        Yn = torch.from_numpy((U - y_mean) / y_scale)
        return net, Splits(Xn[train_idx], Yn[train_idx], Xn[val_idx], Yn[val_idx], torch.from_numpy(y_scale),
                            torch.from_numpy(mix))

    def _new_net(self, n_in: int, n_out: int, feature_names) -> torch.nn.Module:
        """An untrained network of this architecture, float64."""
        if self.architecture == "set":
            return SetNet(n_in, slot_structure(feature_names), self.hidden, n_out, _ACTIVATIONS[self.activation],
                          self.layers, self.encoder_width).double()
        return _Net(n_in, self.hidden, n_out, self.activation, self.layers).double()

    def _optimizer(self, net: _Net):
        """The optimizer and its learning-rate schedule (None for L-BFGS)."""
        if self.optimizer == "lbfgs":
            # 10 iterations per step: with one, torch's L-BFGS can stall for good (measured)
            return torch.optim.LBFGS(net.parameters(), lr=1.0, max_iter=LBFGS_ITERATIONS_PER_STEP, history_size=50,
                                     line_search_fn="strong_wolfe"), None
        opt = torch.optim.Adam(net.parameters(), lr=self.learning_rate, weight_decay=self.weight_decay)
        return opt, torch.optim.lr_scheduler.ReduceLROnPlateau(opt, factor=1 / 3, patience=max(1, self.patience // 4),
                                                               min_lr=self.learning_rate * 1e-3)

    def _train(self, net: _Net, data: "Splits", gen: torch.Generator, progress) -> tuple[dict, dict]:
        """Steps (L-BFGS) or epochs (Adam) until the validation error stalls for ``patience``
        of them or ``max_epochs`` pass: the curve (with ``lbfgs_restarts``) and the best
        weights. Sets ``best_epoch_`` and ``stop_reason_``."""
        opt, sched = self._optimizer(net)
        xt, yt, xv, yv = data.xt, data.yt, data.xv, data.yv
        wt, wv = data.wt, data.wv

        def closure():
            opt.zero_grad(set_to_none=True)
            loss = weighted_loss(net.normalised(xt), yt, wt)
            if self.weight_decay:
                loss = loss + self.weight_decay * sum((p ** 2).sum() for p in net.parameters())
            loss.backward()
            return loss

        curve = {"epoch": [0], "train_mse": [data.mse(net, xt, yt, wt)], "val_mse": [data.mse(net, xv, yv, wv)],
                 "learning_rate": [self.learning_rate]}
        best_val, best_state, best_epoch, stale = curve["val_mse"][0], copy_state(net), 0, 0
        stop_reason, restarts = "max_epochs", 0
        for epoch in range(1, int(self.max_epochs) + 1):
            net.train()
            if sched is None:
                restarts += lbfgs_step(opt, net, closure)
            else:
                adam_epoch(opt, net, xt, yt, int(self.batch_size), gen, wt)
            net.eval()
            tr, va = data.mse(net, xt, yt, wt), data.mse(net, xv, yv, wv)
            if not (math.isfinite(tr) and math.isfinite(va)):
                raise FloatingPointError(f"training diverged at epoch {epoch} ("
                                         + (f"learning_rate {self.learning_rate})" if self.optimizer == "adam" else "L-BFGS)"))
            if sched is not None:
                sched.step(va)
            for key, value in zip(("epoch", "train_mse", "val_mse", "learning_rate"),
                                  (epoch, tr, va, opt.param_groups[0]["lr"])):
                curve[key].append(value)
            if progress is not None:
                progress(epoch, tr, va)
            if va < best_val * (1 - 1e-4):
                best_val, best_state, best_epoch, stale = va, copy_state(net), epoch, 0
            else:
                stale += 1
                if stale >= self.patience:
                    stop_reason = "early_stopping"
                    break
        self.best_epoch_, self.stop_reason_ = best_epoch, stop_reason
        curve["lbfgs_restarts"] = restarts
        return curve, best_state

    def _keep(self, net: _Net, data: "Splits", X: np.ndarray, Y: np.ndarray, train_idx, val_idx, feature_names,
              label_names) -> None:
        """The learned attributes of a fitted model (the best weights are in ``net``)."""
        self.net_ = net
        self.n_features_in_ = X.shape[1]
        self.n_outputs_ = Y.shape[1]
        self.feature_names_ = list(feature_names) if feature_names is not None else [f"x{i}" for i in range(X.shape[1])]
        self.label_names_ = list(label_names) if label_names is not None else ["v_right_mps", "v_left_mps"][: Y.shape[1]]
        self.train_indices_, self.validation_indices_ = train_idx, val_idx
        self.train_mse_ = data.mse(net, data.xt, data.yt)
        self.validation_mse_ = data.mse(net, data.xv, data.yv)
        self.validation_max_abs_error_ = float(np.max(np.abs(self.predict(X[val_idx]) - Y[val_idx])))

    def _split(self, n: int, groups, rng: np.random.Generator):
        if groups is None:
            perm = rng.permutation(n)
            n_val = validation_count(self.validation_fraction, n, "samples")
            return np.sort(perm[n_val:]), np.sort(perm[:n_val])
        groups = np.asarray(groups)
        if groups.shape != (n,):
            raise ValueError(f"groups must have shape ({n},), got {groups.shape}")
        uniq = np.unique(groups)
        if len(uniq) < 2:
            raise ValueError("groups must hold at least two distinct ids")
        n_val = validation_count(self.validation_fraction, len(uniq), "situations")
        val_groups = rng.permutation(uniq)[:n_val]
        is_val = np.isin(groups, val_groups)
        return np.flatnonzero(~is_val), np.flatnonzero(is_val)

    # --- using -----------------------------------------------------------------------
    def _check_fitted(self):
        if not hasattr(self, "net_"):
            raise RuntimeError("this WheelSpeedMLP is not fitted yet: call fit() or load()")

    def predict(self, X) -> np.ndarray:
        """Wheel speeds (n, 2), m/s, unclipped (the exported graph clips to the wheel limits)."""
        self._check_fitted()
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.n_features_in_:
            raise ValueError(f"X must have shape (n, {self.n_features_in_}), got {X.shape}")
        with torch.no_grad():
            x = torch.from_numpy(X)
            y = self.net_(x)
            return (y + current_wheels(x, y.shape[1]) if self.relative else y).numpy()

    def numpy_params(self) -> dict:
        """The learned arrays, float64: x_mean, x_scale, W1 (hidden, in), b1, W1_2, b1_2, ... (further
        hidden layers, if ``layers`` > 1), W2 (out, hidden), b2, y_mean,
        y_scale (of the learned basis) and y_mix (basis -> wheels)."""
        self._check_fitted()
        n = self.net_
        if self.architecture == "set":  # its state, by the module's own names
            return {k: v.detach().numpy().copy() for k, v in n.state_dict().items()}
        return {"x_mean": n.x_mean.numpy().copy(), "x_scale": n.x_scale.numpy().copy(),
                "W1": n.hidden.weight.detach().numpy().copy(), "b1": n.hidden.bias.detach().numpy().copy(),
                **{f"W1_{i + 2}": lin.weight.detach().numpy().copy() for i, lin in enumerate(n.deeper)},
                **{f"b1_{i + 2}": lin.bias.detach().numpy().copy() for i, lin in enumerate(n.deeper)},
                "W2": n.out.weight.detach().numpy().copy(), "b2": n.out.bias.detach().numpy().copy(),
                "y_mean": n.y_mean.numpy().copy(), "y_scale": n.y_scale.numpy().copy(),
                "y_mix": n.y_mix.numpy().copy()}

    # --- files -----------------------------------------------------------------------
    def save(self, model_dir, provenance: dict | None = None, arrays: dict | None = None) -> Path:
        """Write the fitted model to ``model_dir`` with ``provenance`` (into ``model.json``, then the ONNX file) and
        ``arrays`` as ``<name>.npy``. ``model.json`` goes first and comes back last: a save interrupted over
        an older model leaves no model folder, not new weights under the older model's metadata."""
        self._check_fitted()
        from casadi_gpc.io import atomic_file, write_json
        model_dir = Path(model_dir)
        (model_dir / "model.json").unlink(missing_ok=True)
        for name, array in {"validation_indices": self.validation_indices_, **(arrays or {})}.items():
            with atomic_file(model_dir / f"{name}.npy") as tmp:
                np.save(tmp, array)
        with atomic_file(model_dir / "weights.npz") as tmp:
            np.savez(tmp, **self.numpy_params())
        write_json(model_dir / "training_curve.json", self.curve_)
        save_curve_figure(self.curve_, model_dir / "training_curve.png", LBFGS_ITERATIONS_PER_STEP)
        write_json(model_dir / "model.json", {
            "format": MODEL_FORMAT, "params": self.get_params(), "n_features": self.n_features_in_,
            "n_outputs": self.n_outputs_, "feature_names": self.feature_names_, "label_names": self.label_names_,
            "train_mse": self.train_mse_, "validation_mse": self.validation_mse_,
            "validation_rmse_mps": math.sqrt(self.validation_mse_), "validation_max_abs_error_mps":
            self.validation_max_abs_error_, "n_train": int(len(self.train_indices_)),
            "n_validation": int(len(self.validation_indices_)), "best_epoch": self.best_epoch_,
            "stop_reason": self.stop_reason_, "provenance": provenance or {}})
        self.provenance_ = dict(provenance or {})
        return model_dir

    @classmethod
    def load(cls, model_dir) -> "WheelSpeedMLP":
        """A fitted model from a folder written by :meth:`save`."""
        model_dir = Path(model_dir)
        meta_path = model_dir / "model.json"
        if not meta_path.is_file():
            raise FileNotFoundError(f"{model_dir}: not a trained model folder (no model.json)")
        meta = json.loads(meta_path.read_text())
        if meta.get("format") != MODEL_FORMAT:
            raise ValueError(f"{meta_path}: format {meta.get('format')!r}, expected {MODEL_FORMAT!r}")
        self = cls(**meta["params"])
        try:
            with np.load(model_dir / "weights.npz", allow_pickle=False) as w:
                arrays = {k: w[k] for k in w.files}
        except UNREADABLE_NPZ as exc:  # (a BadZipFile traceback in export)
            raise ValueError(f"weights.npz: not a readable weights file ({exc or type(exc).__name__})") from None
        net = self._new_net(meta["n_features"], meta["n_outputs"], meta["feature_names"])
        if self.architecture == "set":
            net.load_state_dict({k: torch.from_numpy(v) for k, v in arrays.items()})
        else:
            _load_mlp(net, arrays)
        self.net_ = net.eval()
        self._loaded(meta, model_dir)
        return self

    def _loaded(self, meta: dict, model_dir: Path) -> None:
        """The learned attributes :meth:`load` reads from ``model.json`` and beside it."""
        self.n_features_in_, self.n_outputs_ = meta["n_features"], meta["n_outputs"]
        self.feature_names_, self.label_names_ = meta["feature_names"], meta["label_names"]
        self.train_mse_, self.validation_mse_ = meta["train_mse"], meta["validation_mse"]
        self.validation_max_abs_error_ = meta["validation_max_abs_error_mps"]
        self.best_epoch_, self.stop_reason_ = meta["best_epoch"], meta["stop_reason"]
        self.provenance_ = meta.get("provenance", {})
        vi = model_dir / "validation_indices.npy"
        self.validation_indices_ = np.load(vi) if vi.is_file() else None
        curve = model_dir / "training_curve.json"
        self.curve_ = json.loads(curve.read_text()) if curve.is_file() else None


def _load_mlp(net: _Net, arrays: dict) -> None:
    """The perceptron's weights from the arrays of :meth:`WheelSpeedMLP.numpy_params`."""
    with torch.no_grad():
        net.hidden.weight.copy_(torch.from_numpy(arrays["W1"]))
        net.hidden.bias.copy_(torch.from_numpy(arrays["b1"]))
        for i, lin in enumerate(net.deeper):
            lin.weight.copy_(torch.from_numpy(arrays[f"W1_{i + 2}"]))
            lin.bias.copy_(torch.from_numpy(arrays[f"b1_{i + 2}"]))
        net.out.weight.copy_(torch.from_numpy(arrays["W2"]))
        net.out.bias.copy_(torch.from_numpy(arrays["b2"]))
        for k in ("x_mean", "x_scale", "y_mean", "y_scale"):
            getattr(net, k).copy_(torch.from_numpy(arrays[k]))
        if "y_mix" in arrays:
            net.y_mix.copy_(torch.from_numpy(arrays["y_mix"]))
