"""Write the Cascaded Tanks estimation/validation recordings for `pdmkit mismatch`.

Source: $PDMKIT_DATA/cascaded_tanks/dataBenchmark.mat (else ../shared/data beside the
repository): uEst/yEst (estimation) and uVal/yVal (validation), 1024 samples each,
Ts = 4 s.  u is the pump voltage (V), y the lower-tank level sensor (V; it saturates
at 10 V).  Columns written: time (s), u, h2 (= y).  The record is short (1024 samples,
about 70 min) and the dynamics slow, so there is nothing to decimate.
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "out",
        nargs="?",
        default=str(HERE / "data"),
        help="output folder (default examples/cascaded_tanks/data)",
    )
    a = ap.parse_args(argv)
    mat = loadmat(data_root() / "cascaded_tanks" / "dataBenchmark.mat")
    col = lambda k: np.asarray(mat[k], float).ravel()  # noqa: E731
    ts = float(np.asarray(mat["Ts"]).ravel()[0])
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, u, y in (
        ("estimation", col("uEst"), col("yEst")),
        ("validation", col("uVal"), col("yVal")),
    ):
        df = pd.DataFrame({"time": np.arange(u.size) * ts, "u": u, "h2": y})
        df.to_csv(out / f"{name}.csv", index=False)
        print(f"wrote {out / (name + '.csv')} ({len(df)} samples, Ts = {ts:g} s)")


if __name__ == "__main__":
    main()
