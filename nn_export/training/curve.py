"""The training curve's figure (the paper's Fig. 6), from the curve a fit records."""
from __future__ import annotations

__all__ = ["save_curve_figure"]


def save_curve_figure(curve: dict, path, lbfgs_iterations: int = 10) -> None:
    """The paper's Fig. 6: error against training iteration (epoch), training and validation;
    ``lbfgs_iterations``: the L-BFGS iterations of one step (the x axis's unit)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from casadi_gpc.io import save_figure
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    ax.semilogy(curve["epoch"], curve["train_mse"], label=f"training ({curve.get('n_train', '?')} samples)")
    ax.semilogy(curve["epoch"], curve["val_mse"], label=f"validation ({curve.get('n_validation', '?')} samples)")
    if "best_epoch" in curve:
        ax.axvline(curve["best_epoch"], color="0.6", ls="--", lw=0.8, label="kept (best validation)")
    ax.set_xlabel(f"L-BFGS step ({lbfgs_iterations} iterations)" if curve.get("optimizer", "lbfgs") == "lbfgs" else "epoch (Adam)")
    ax.set_ylabel("mean squared wheel-speed error, (m/s)$^2$")
    ax.set_title("Training error (cf. paper Fig. 6)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
