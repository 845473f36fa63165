"""Allan deviation of two datasheet gyros: a MEMS and a tactical FOG, recovered figures against the datasheet.

A gyro datasheet gives the angle random walk (ARW), the bias instability
``B`` and sometimes the averaging time of the Allan minimum. The script
builds two gyros from the presets of :data:`attitude.sensors.GYRO_PRESETS`
(:meth:`attitude.sensors.Gyro.preset`, i.e. :meth:`Gyro.from_datasheet`):

- ``"mems"``: ADIS16470 class, ARW 0.34 deg/sqrt(h), B = 8 deg/h, minimum
  assumed at 100 s;
- ``"tactical"``: LN-200 class, ARW 0.07 deg/sqrt(h), B = 1 deg/h, minimum
  assumed at 300 s;

simulates each at rest (:func:`attitude.allan.gyro_allan_deviation`: the
exact sampling of the noise model), and reads the figures back from the
Allan curve the way a lab does with a real record (IEEE Std 952-1997,
Annex C):

- ARW: the slope -1/2 line ``N / sqrt(tau)`` fitted over the shortest
  averaging times (tau <= 1 s, where the white rate noise dominates);
  ``ARW [deg/sqrt(h)] = N [deg/h sqrt(s)] / 60``;
- bias instability: the floor of the curve divided by
  ``sqrt(2 ln 2 / pi) = 0.664``, and its averaging time. The floor is read
  as the first point where the curve stops falling (the plateau after the
  slope -1/2), not as its global minimum: the presets model the bias
  instability as a first-order Gauss-Markov bias
  (:func:`attitude.sensors.bias_instability_to_gauss_markov`), whose Allan
  deviation is flat around its correlation time and falls again as
  ``1/sqrt(tau)`` beyond it (the bias averages out), where true flicker
  noise would stay flat. A 10 h record shows that fall; the global minimum
  then sits at the longest tau and would understate ``B`` several times.
  The plateau is flat within a few percent over about a decade of tau, so
  the averaging time read from it (on an octave grid) is a coarse figure;
  ``B`` is the robust one.

The recovered figures come with the chi-square confidence interval of the
point they are read from, so a difference to the datasheet can be judged
against the record's length. Figures: one Allan plot per gyro (curve,
1-sigma band, the model's exact curve, the datasheet lines) and both curves
on one axes.

Run ``python examples/gyro_allan_deviation.py --out DIR`` (``--quick`` for
a short record).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from attitude.allan import AllanDeviation, gyro_allan_deviation, plateau_index
from attitude.sensors import BIAS_INSTABILITY_FLOOR_FACTOR, GYRO_PRESETS, Gyro

DEG_PER_H = np.pi / 180.0 / 3600.0  # 1 deg/h in rad/s
PERIOD_S = 0.1  # 10 Hz output
GRADES = ("mems", "tactical")


def recovered_arw(result: AllanDeviation, tau_max_s: float = 1.0) -> tuple[float, float, float]:
    """ARW [deg/sqrt(h)] from a slope -1/2 fit over ``tau <= tau_max_s``, with the band of its 1 s point.

    Parameters
    ----------
    result : AllanDeviation
        The curve.
    tau_max_s : float
        Longest averaging time of the fit [s].

    Returns
    -------
    tuple of float
        ``(arw, arw_low, arw_high)`` [deg/sqrt(h)]: the fit and the confidence
        interval of the curve at the longest fitted ``tau`` scaled the same way.
    """
    short = result.tau <= tau_max_s
    n_deg_per_h_sqrt_s = np.exp(np.mean(np.log(result.adev[short] / DEG_PER_H) + 0.5 * np.log(result.tau[short])))
    last = np.flatnonzero(short)[-1]
    scale = np.sqrt(result.tau[last]) / DEG_PER_H / 60.0
    return n_deg_per_h_sqrt_s / 60.0, result.adev_low[last] * scale, result.adev_high[last] * scale


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/gyro_allan_deviation"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="shorter records (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    # Octave taus reach a tenth of the record: 10 h puts the longest tau at about 1 h, well past
    # both assumed minima (100 s, 300 s), so the floor is seen from both sides.
    duration_s = 3000.0 if args.quick else 36000.0

    results = {}
    for seed, grade in enumerate(GRADES, start=1):
        figures = GYRO_PRESETS[grade]["figures"]
        gyro = Gyro.preset(grade, period=PERIOD_S)
        sheet = {k: figures[k] for k in ("arw_deg_per_sqrt_h", "bias_instability_deg_per_h", "bias_instability_time_s")}
        result = gyro_allan_deviation(gyro, duration_s, rng=seed, datasheet=sheet)
        results[grade] = result

        arw, arw_lo, arw_hi = recovered_arw(result)
        to_b = 1.0 / DEG_PER_H / BIAS_INSTABILITY_FLOOR_FACTOR  # rad/s of the floor -> B [deg/h]
        i_min, i_model = plateau_index(result.adev), plateau_index(result.model_adev)
        b, b_lo, b_hi = result.adev[i_min] * to_b, result.adev_low[i_min] * to_b, result.adev_high[i_min] * to_b
        tau_sheet = figures["bias_instability_time_s"]
        global_tau, global_adev = result.floor()
        print(f"{grade} ({GYRO_PRESETS[grade]['source'].split(':')[0]}), {duration_s:g} s at {1 / PERIOD_S:g} Hz:")
        print(f"  ARW   {arw:.4f} deg/sqrt(h)  (1-sigma band at tau = 1 s: {arw_lo:.4f} .. {arw_hi:.4f}); "
              f"datasheet {figures['arw_deg_per_sqrt_h']:g}")  # fmt: skip
        print(f"  B     {b:.3f} deg/h (plateau / 0.664; band {b_lo:.3f} .. {b_hi:.3f}); "
              f"datasheet {figures['bias_instability_deg_per_h']:g}; "
              f"model curve's plateau {result.model_adev[i_model] * to_b:.3f}")  # fmt: skip
        print(f"  tau   {result.tau[i_min]:g} s at the plateau on the octave grid; datasheet (assumed) "
              f"{tau_sheet:g} s; model curve's plateau on the grid {result.tau[i_model]:g} s")  # fmt: skip
        if global_tau > result.tau[i_min]:
            print(f"  (global minimum {global_adev / DEG_PER_H:.3f} deg/h at {global_tau:g} s: the Gauss-Markov "
                  "bias averaging out, not the floor)")  # fmt: skip
        if result.tau[-1] < 2.0 * tau_sheet:
            print(f"  (the record reaches tau = {result.tau[-1]:g} s only: the plateau is not resolved)")
        result.save_figure(
            args.out / f"allan_{grade}.png",
            title=f"{grade} gyro (Gyro.preset({grade!r})): {duration_s / 3600:.3g} h at rest, {1 / PERIOD_S:g} Hz",
        )

    fig = Figure(figsize=(7.5, 5.0), layout="constrained")
    ax = fig.subplots()
    for colour, (grade, result) in zip(("C0", "C1"), results.items(), strict=True):
        ax.fill_between(result.tau, result.adev_low / DEG_PER_H, result.adev_high / DEG_PER_H, color=colour, alpha=0.25)
        ax.loglog(result.tau, result.adev / DEG_PER_H, "o-", ms=3, color=colour, label=f"{grade} (1-sigma band)")
        ax.loglog(result.tau, result.model_adev / DEG_PER_H, "k-", lw=0.8)
        b = GYRO_PRESETS[grade]["figures"]["bias_instability_deg_per_h"]
        floor = BIAS_INSTABILITY_FLOOR_FACTOR * b
        ax.axhline(floor, ls="--", color=colour, lw=1, label=f"{grade}: 0.664 B, B = {b:g} deg/h")
    ax.plot([], [], "k-", lw=0.8, label="model (exact)")
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel("Allan deviation [deg/h]")
    ax.set_title("MEMS against tactical gyro at rest")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.savefig(args.out / "allan_mems_vs_tactical.png", dpi=120)
    print(f"figures in {args.out}/ ({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
