"""Write the Silverbox estimation/validation recordings for `pdmkit mismatch`.

Source: SNLS80mV.mat (V1 input voltage, V2 output voltage, 131072 samples,
fs = 610.35 Hz) from $PDMKIT_DATA/silverbox, else ../shared/data/silverbox beside the
repository.  Split as in the official nonlinearbenchmark.org loader
(nonlinear_benchmarks.Silverbox, 0-based Python slices):

  estimation  samples 40650:127400  the odd random-phase multisines (86 750 samples)
  validation  samples   100:40575   the "arrow": filtered noise of growing amplitude,
                                    ending in the arrow-head that goes beyond the
                                    estimation amplitude (40 475 samples)

`--arrow first40000` uses samples 0:40000 instead (the "first 40 000 samples"
convention of older papers; it cuts the last ~500 samples of the arrow-head).
Offsets: as the Silverbox README advises, the record means of V1 and V2 are removed
(the input is designed zero-mean; `--keep-offset` keeps the raw values).

Input hold: V1 is a smooth band-limited voltage at only ~9 samples per period of the
resonance.  Held constant between samples (zero-order hold) it lags by half a sample
(0.8 ms, ~20 degrees at 69 Hz), an error larger than the Duffing term.  pdmkit since
commit da3a9f0 interpolates such inputs linearly (`--input-hold auto` picks `foh` for
this record), so the default here writes the raw samples (`--input-hold sample`).
With an older pdmkit that always holds inputs, or with `pdmkit mismatch --input-hold
zoh`, use `--input-hold midpoint`: the value held over [t_k, t_k+1) is then the mean of
the two end samples, which removes the half-sample lag to first order.

The resonance is near 69 Hz, only ~9 samples per period: do NOT decimate for a real
study (`--decimate` exists for smoke tests only and warns).  To shorten a run, use
`--est-samples N` (first N samples of the multisine part) and/or `--val-samples N`.
"""

import argparse
import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.io import loadmat

HERE = Path(__file__).resolve().parent
FS = 610.35


def data_root() -> Path:
    env = os.environ.get("PDMKIT_DATA")
    return Path(env) if env else HERE.parents[2] / "shared" / "data"


def frame(u, y, step):
    t = np.arange(u.size) * step / FS
    return pd.DataFrame({"time": t, "V1": u, "V2": y})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "out",
        nargs="?",
        default=str(HERE / "data"),
        help="output folder (default examples/silverbox/data)",
    )
    ap.add_argument(
        "--decimate",
        type=int,
        default=1,
        help="keep one sample in N (default 1: none; aliases the 69 Hz mode, smoke "
        "tests only)",
    )
    ap.add_argument(
        "--est-samples",
        type=int,
        default=None,
        help="use only the first N samples of the estimation part",
    )
    ap.add_argument(
        "--val-samples",
        type=int,
        default=None,
        help="use only the first N samples of the validation part",
    )
    ap.add_argument("--arrow", choices=["full", "first40000"], default="full")
    ap.add_argument(
        "--input-hold",
        choices=["sample", "midpoint"],
        default="sample",
        help="V1 as sampled (default; for pdmkit's foh/auto input hold) or the mean of "
        "neighbouring samples (for --input-hold zoh)",
    )
    ap.add_argument(
        "--keep-offset", action="store_true", help="do not remove the record means"
    )
    a = ap.parse_args(argv)

    mat = loadmat(data_root() / "silverbox" / "SNLS80mV.mat")
    u = np.asarray(mat["V1"], float).ravel()
    y = np.asarray(mat["V2"], float).ravel()
    if not a.keep_offset:
        u = u - u.mean()
        y = y - y.mean()
    if a.input_hold == "midpoint":
        u = 0.5 * (u + np.r_[u[1:], u[-1]])
    est = slice(40650, 127400)
    val = slice(100, 40575) if a.arrow == "full" else slice(0, 40000)
    ue, ye, uv, yv = u[est], y[est], u[val], y[val]
    if a.est_samples:
        ue, ye = ue[: a.est_samples], ye[: a.est_samples]
    if a.val_samples:
        uv, yv = uv[: a.val_samples], yv[: a.val_samples]
    n = max(1, a.decimate)
    if n > 1:
        print(
            f"warning: --decimate {n} leaves {FS / n / 69:.1f} samples per period of "
            "the 69 Hz resonance",
            file=sys.stderr,
        )
        # block mean of the input (held between samples), point samples of the output
        m_e, m_v = ue.size // n * n, uv.size // n * n
        ue, ye = ue[:m_e].reshape(-1, n).mean(1), ye[:m_e:n]
        uv, yv = uv[:m_v].reshape(-1, n).mean(1), yv[:m_v:n]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    frame(ue, ye, n).to_csv(out / "estimation.csv", index=False)
    frame(uv, yv, n).to_csv(out / "validation.csv", index=False)
    print(
        f"wrote {out / 'estimation.csv'} ({ue.size} samples) and "
        f"{out / 'validation.csv'} ({uv.size} samples), dt = {n / FS:.6g} s"
    )


if __name__ == "__main__":
    main()
