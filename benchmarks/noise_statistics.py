"""Are the network's draws uniform and independent? Draws of the motor neurons' two sites
(the noise and the threshold) for 20 trials over many steps, as the numpy target makes them.

    python benchmarks/noise_statistics.py [--steps 3000] [--trials 20]

Prints the mean (1/2), the variance (1/12), and the correlations between consecutive steps,
neighbouring cells, cells four apart (another Philox block), the two sites of one cell and
step, and two trials; each beside its standard error, 1/sqrt(pairs).
"""

from __future__ import annotations

import argparse

import numpy as np
from brian2.codegen.runtime.numpy_rt.numpy_rt import LazyArange

from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import noise
from astrocpg.network.layout import Layout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--trials", type=int, default=20)
    args = ap.parse_args()
    per = Layout(n_trials=1, pool_size=int(DEFAULT_MODELS.value("pool_size"))).motor_per_trial
    n = per * args.trials
    seed, cell = noise.trial_major(np.arange(n), per, list(range(1, args.trials + 1)))
    offset = np.zeros(1, dtype=np.int64)
    sites = [noise.SiteStream(name=f"s{k}", site=noise.site_id("motor", k), seed=seed, cell=cell,
                              cells_per_trial=per, offset=offset) for k in (0, 1)]
    x, y = (np.array([s.uniform(t, LazyArange(n)) for t in range(args.steps)]) for s in sites)

    def corr(a: np.ndarray, b: np.ndarray) -> str:
        return f"{np.corrcoef(a.ravel(), b.ravel())[0, 1]:+.5f} (se {1 / np.sqrt(a.size):.5f})"

    print(f"{x.size + y.size} draws; mean {x.mean():.5f} (1/2), variance {x.var():.6f} "
          f"(1/12 = {1 / 12:.6f})")
    print("consecutive steps  ", corr(x[1:], x[:-1]))
    print("neighbouring cells ", corr(x[:, 1:], x[:, :-1]))
    print("cells four apart   ", corr(x[:, 4:], x[:, :-4]))
    print("the two sites      ", corr(x, y))
    print("trial 0 and trial 1", corr(x[:, :per], x[:, per:2 * per]))


if __name__ == "__main__":
    main()
