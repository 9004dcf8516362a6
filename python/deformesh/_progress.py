"""Progress of a long job: a tqdm bar where tqdm is installed, plain lines
on stderr at each tenth of pseudo-time otherwise; none with progress=False."""

from __future__ import annotations

import sys


class _Lines:
    def __init__(self) -> None:
        self.last = -1

    def __call__(self, algorithm: int, t: float, steps: int, halved: int) -> None:
        # algorithm 2 starts again at t = 0: deciles of each in turn
        decile = 100 * algorithm + int(t * 10 + 1e-9)
        if decile > self.last:
            self.last = decile
            print(f"algorithm {algorithm}: t = {t:.3f}  steps {steps}  halved {halved}", file=sys.stderr, flush=True)

    def close(self) -> None:
        pass


class _Bar:
    def __init__(self, tqdm) -> None:
        self.bar = tqdm(total=1000, desc="deformesh", unit="‰", leave=False)

    def __call__(self, algorithm: int, t: float, steps: int, halved: int) -> None:
        self.bar.set_postfix_str(f"algorithm {algorithm}  t = {t:.3f}  steps {steps}  halved {halved}", refresh=False)
        self.bar.n = int(t * 1000)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()


def reporter(progress):
    """The callable the extension calls, and how to close it: `progress` is
    True (a bar or lines), False or None (nothing), or a callable
    f(algorithm, t, steps, halved)."""
    if progress is None or progress is False:
        return None, lambda: None
    if callable(progress) and progress is not True:
        return progress, lambda: None
    try:
        from tqdm import tqdm
    except ImportError:
        r = _Lines()
    else:
        r = _Bar(tqdm)
    return r, r.close
