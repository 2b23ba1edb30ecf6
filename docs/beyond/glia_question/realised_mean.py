"""The graded astrocyte's realised mean [ADO] in its trainings, per drive, as the glia
question's rules read it (RULES.md, "Matched means"): r_ADO x tau_ADO x its releases per
astrocyte and second, r_ADO * tau_ADO * sum(adenosine_releases) / (8 * sum(length_s)) over
every session of every seed of the run (the astrocytes of a trial as the network's layout
counts them: one per thigh pool, 8). It is reported beside the results, not a criterion for keeping or dropping a run.

    python docs/beyond/glia_question/realised_mean.py docs/beyond/glia_drive/results_graded.csv.gz

r_ADO and tau_ADO are read from the shipped model file (``graded_astrocyte``).
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

from astrocpg.models.compose import model_set
from astrocpg.network.layout import Layout
from astrocpg.support.shipped import resolve


def realised(results: str, astrocyte: str = "graded_astrocyte") -> pd.DataFrame:
    text = resolve(astrocyte, "model").read_text(encoding="utf-8")
    models = model_set(models={"astrocyte": text})
    r_ado = float(models.parameter("r_ADO").value)
    tau_ado = float(models.parameter("tau_ADO").value)
    rows = pd.read_csv(results)
    rows = rows[rows["astrocyte"] == astrocyte]
    # one astrocyte per thigh pool: the layout's count (it does not depend on the pool size)
    astrocytes = Layout(n_trials=1, pool_size=1).cells_per_trial("astrocyte")
    out = []
    for drive, g in rows.groupby("I_background_0", sort=False):
        releases_per_s = g["adenosine_releases"].sum() / (astrocytes * g["length_s"].sum())
        out.append({"I_background_0": drive, "seeds": g["seed"].nunique(),
                    "sessions": len(g), "releases_per_astrocyte_s": releases_per_s,
                    "mean_ADO": r_ado * tau_ado * releases_per_s})
    return pd.DataFrame(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("results", help="a study's results.csv or results.csv.gz")
    a = p.parse_args(argv)
    table = realised(a.results)
    print("| I_background_0 | seeds | sessions | releases per astrocyte and s | mean [ADO] |")
    print("|---|---|---|---|---|")
    for r in table.itertuples():
        print(f"| {r.I_background_0} | {r.seeds} | {r.sessions} | "
              f"{r.releases_per_astrocyte_s:.3f} | {r.mean_ADO:.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
