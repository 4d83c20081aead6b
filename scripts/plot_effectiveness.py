"""SPEC Fig. 10: actuator effectiveness against altitude at EAS 10 m/s, normalised to sea level.

    python scripts/plot_effectiveness.py --out results/effectiveness   # PNG + JSON
    python scripts/plot_effectiveness.py --json                         # figures only
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from jsbsim_env.effectiveness import effectiveness

PANELS = (("aileron", "roll"), ("elevator", "pitch"), ("rudder", "yaw"))


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h_km = np.array([r["altitude_m"] for r in rows]) / 1000.0
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for ax, (surface, axis), letter in zip(axes.flat, PANELS, "abc"):
        ax.plot(h_km, [r[f"{surface}_moment_nm_per_deg_normalised"] for r in rows], "o-",
                label=f"{axis} moment per degree")
        ax.plot(h_km, [r[f"{surface}_rate_degps_per_deg_normalised"] for r in rows], "s--",
                label=f"steady {axis} rate per degree")
        ax.set_title(f"({letter}) {surface}")
    ax = axes.flat[3]
    ax.plot(h_km, [r["thrust_full_throttle_n_normalised"] for r in rows], "o-", label="thrust at full throttle")
    ax.plot(h_km, [r["thrust_trim_n_normalised"] for r in rows], "s--", label="thrust in trim (= drag)")
    ax.set_title("(d) propulsion")
    for ax in axes.flat:
        ax.axhline(1.0, color="0.6", lw=0.8)
        ax.set_ylabel("relative to 0 km")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("altitude, km")
    fig.suptitle("Actuator effectiveness against altitude, EAS 10 m/s")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="folder for effectiveness.png and effectiveness.json")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--veas-mps", type=float, default=10.0)
    parser.add_argument("--step-km", type=float, default=2.0)
    args = parser.parse_args()
    altitudes_m = np.arange(0.0, 20000.0 + 1.0, args.step_km * 1000.0)
    rows = effectiveness(altitudes_m.tolist(), args.veas_mps)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        plot(rows, args.out / "effectiveness.png")
        (args.out / "effectiveness.json").write_text(json.dumps(rows, indent=2))
        print(f"wrote {args.out / 'effectiveness.png'} and effectiveness.json")
    if args.json or not args.out:
        print(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
