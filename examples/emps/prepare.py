"""Write the EMPS estimation/validation recordings for `pdmkit mismatch`.

Source: $PDMKIT_DATA/emps (else ../shared/data/emps beside the repository):
DATA_EMPS.mat (estimation) and DATA_EMPS_PULSES.mat (validation, with force pulses),
24 841 samples each at 1 kHz.  Columns written (one file serves both model files):

  time   s, from 0
  F      force on the load, N = gtau * vir (gtau = 35.15 N/V, stored in the files);
         input of model.py (open loop)
  qr     reference position qg, m; input of model_closed_loop.py
  pulse  pulse command pulses_N (0 or 5; the recorded command vir jumps by 5 V at
         each step, so model_closed_loop.py adds it to the control voltage); zero in
         the estimation record
  q      measured motor position on the load side qm, m (output of both models)

`--decimate N` keeps one sample in N.  pdmkit holds an input constant between samples,
so the inputs F, qr and pulse are block means over the N samples that follow each kept
sample (a point-sampled reference ramp held for N ms would lag the true one by half a
sample, 1 mm at 0.2 m/s for N = 10, more than the tracking error the closed-loop model
has to explain); the output q is point-sampled.
The closed-loop dynamics are near 20 Hz, so N = 10 (100 Hz) still resolves them.
"""

import argparse
import os
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.io import loadmat

HERE = Path(__file__).resolve().parent


def data_root() -> Path:
    env = os.environ.get("PDMKIT_DATA")
    return Path(env) if env else HERE.parents[2] / "shared" / "data"


def load(path: Path, n: int) -> pd.DataFrame:
    mat = loadmat(path)
    col = lambda k: np.asarray(mat[k], float).ravel()  # noqa: E731
    t, vir, qg, qm = col("t"), col("vir"), col("qg"), col("qm")
    gtau = float(np.asarray(mat["gtau"]).ravel()[0])
    pulse = col("pulses_N") if "pulses_N" in mat else np.zeros_like(t)
    force = gtau * vir
    if n > 1:
        m = t.size // n * n
        block = lambda a: a[:m].reshape(-1, n).mean(1)  # noqa: E731
        t, qm = t[:m:n], qm[:m:n]
        force, qg, pulse = block(force), block(qg), block(pulse)
    dt = round(
        float(t[-1] - t[0]) / (t.size - 1), 6
    )  # the file's t steps carry float noise (median 0.999984 ms)
    time = np.arange(t.size) * dt  # exactly uniform (the file's t has rounding noise)
    return pd.DataFrame({"time": time, "F": force, "qr": qg, "pulse": pulse, "q": qm})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "out",
        nargs="?",
        default=str(HERE / "data"),
        help="output folder (default examples/emps/data)",
    )
    ap.add_argument(
        "--decimate",
        type=int,
        default=1,
        help="keep one sample in N (default 1: full 1 kHz record)",
    )
    a = ap.parse_args(argv)
    root = data_root() / "emps"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    n = max(1, a.decimate)
    for name, src in (
        ("estimation", "DATA_EMPS.mat"),
        ("validation", "DATA_EMPS_PULSES.mat"),
    ):
        df = load(root / src, n)
        df.to_csv(out / f"{name}.csv", index=False)
        print(
            f"wrote {out / (name + '.csv')} ({len(df)} samples, "
            f"dt = {df.time[1]:.4g} s) from {src}"
        )


if __name__ == "__main__":
    main()
