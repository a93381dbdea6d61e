"""Kinematics benchmark: kinegym vs roboticstoolbox-python on the PhantomX Pincher.

Run (one core, as the targets are stated per core)::

    pip install roboticstoolbox-python      # only for this benchmark
    taskset -c 0 python bench/bench_kinematics.py [--n 2000] [--reps 3]

Same 2000 random reachable targets for everyone: FK of joint angles drawn uniformly inside
the Pincher's joint limits (``configs/arms/pincher.yaml``). Accuracy is matched: success
means tip error < 1e-4 cm (and pitch < 1e-4 rad when asked) inside the joint limits; rtb's
``tol`` (on 0.5 |e|^2) is set to 5e-11 so that its answers are as accurate as ours.
Each figure is the median over ``--reps`` repetitions of per-call ``perf_counter`` timings.
Without roboticstoolbox installed, only kinegym's figures are printed.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from kinegym.kinematics import WritingArm
from kinegym.kinematics.ik import ArmSeeds, solve_arm


def per_call(fn: Callable, calls: Sequence[tuple], reps: int) -> tuple[float, float, list]:
    """Median and p95 (microseconds) of per-call times; median over repetitions."""
    meds, p95s, out = [], [], []
    pc = time.perf_counter
    for _ in range(reps):
        ts = np.empty(len(calls))
        out = []
        for i, a in enumerate(calls):
            t0 = pc()
            r = fn(*a)
            ts[i] = pc() - t0
            out.append(r)
        meds.append(np.median(ts) * 1e6)
        p95s.append(np.percentile(ts, 95) * 1e6)
    return float(np.median(meds)), float(np.median(p95s)), out


def throughput(fn: Callable[[], object], n: int, reps: int) -> float:
    """Items per second of one batched call over ``n`` items (best of ``reps``)."""
    best = math.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return n / best


def ok_solution(arm: WritingArm, q: object, target: np.ndarray, pitch: bool) -> bool:
    if q is None:
        return False
    q = np.asarray(q, dtype=float)
    f = arm.fk(q)
    good = np.linalg.norm(f[:3] - target[:3]) < 1e-4 and bool(arm.within_limits(q))
    if pitch:
        good &= abs(math.remainder(f[3] - target[3], 2 * math.pi)) < 1e-4
    return bool(good)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--batch", type=int, default=200_000)
    args = ap.parse_args()

    arm = WritingArm.from_config("pincher")
    rng = np.random.default_rng(5)
    q_true = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (args.n, 4))
    targets = arm.fk(q_true)
    rows: list[tuple[str, str, str, str]] = []

    # --- analytic IK
    calls = [tuple(t) for t in targets.tolist()]
    med, p95, res = per_call(arm.ik_fast, calls, args.reps)
    succ = np.mean([ok_solution(arm, r, t, True) for r, t in zip(res, targets)])
    rows.append(("analytic IK, ik_fast (1 target)", f"{succ:.1%}", f"{med:.2f}", f"{p95:.2f}"))
    med2, p952, _ = per_call(lambda t: arm.ik(t), [(t,) for t in targets], args.reps)
    rows.append(("analytic IK, ik (checked, ndarray)", "", f"{med2:.2f}", f"{p952:.2f}"))
    big = arm.fk(rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (args.batch, 4)))
    ik_rate = throughput(lambda: arm.ik_all(big), args.batch, args.reps)
    rows.append((f"analytic IK, ik_all batch of {args.batch}", "", f"{ik_rate / 1e6:.2f} M/s", ""))

    # --- numeric DLS
    t0 = time.perf_counter()
    seeds = ArmSeeds(arm)
    build = time.perf_counter() - t0
    for mask in ("position", "position+pitch"):
        pitch = mask.endswith("pitch")
        med, p95, res = per_call(
            lambda t, m=mask: solve_arm(arm, t, m, seeds=seeds, rng=np.random.default_rng(0)),
            [(t,) for t in targets], args.reps)
        succ = np.mean([r.success and ok_solution(arm, r.q, t, pitch) for r, t in zip(res, targets)])
        its = np.mean([r.iterations for r in res])
        rows.append((f"numeric DLS IK, {mask} ({its:.1f} it)", f"{succ:.1%}", f"{med:.1f}", f"{p95:.1f}"))

    # --- DH forward kinematics
    chain = arm.dh_chain()
    med, p95, _ = per_call(chain.fk_fast, [tuple(q) for q in q_true.tolist()], args.reps)
    rows.append(("DH FK, fk_fast (1 config, 4x4 pose)", "", f"{med:.2f}", f"{p95:.2f}"))
    med, p95, _ = per_call(chain.fk, [(q,) for q in q_true], args.reps)
    rows.append(("DH FK, fk (1 config, ndarray)", "", f"{med:.2f}", f"{p95:.2f}"))
    qbig = rng.uniform(-3, 3, (args.batch, 4))
    fk_rate = throughput(lambda: chain.fk(qbig), args.batch, args.reps)
    rows.append((f"DH FK, fk batch of {args.batch} (N,4,4)", "", f"{fk_rate / 1e6:.2f} M/s", ""))

    # --- roboticstoolbox, same targets
    try:
        import roboticstoolbox as rtb
        from roboticstoolbox import ET
    except ImportError:
        rtb = None
    if rtb is not None:
        qlim = [{"qlim": arm.limits[j]} for j in range(4)]
        ets = (ET.Rz(**qlim[0]) * ET.tz(arm.shoulder_height) * ET.Ry(flip=True, **qlim[1])
               * ET.tx(arm.upper_arm) * ET.Ry(flip=True, **qlim[2]) * ET.tx(arm.forearm)
               * ET.Ry(flip=True, **qlim[3]) * ET.tx(arm.tool))
        poses = [ets.eval(q) for q in q_true]
        assert max(np.abs(p[:3, 3] - t[:3]).max() for p, t in zip(poses, targets)) < 1e-9
        for mask, m in (("position", [1, 1, 1, 0, 0, 0]), ("position+pitch", [1] * 6)):
            med, p95, res = per_call(
                lambda p, m=m: ets.ik_LM(p, mask=np.array(m, float), joint_limits=True, tol=5e-11),
                [(p,) for p in poses], args.reps)
            succ = np.mean([r.success and ok_solution(arm, r.q, t, mask.endswith("pitch"))
                            for r, t in zip(res, targets)])
            rows.append((f"rtb {rtb.__version__} ets.ik_LM, {mask}", f"{succ:.1%}", f"{med:.1f}", f"{p95:.1f}"))
        med, p95, _ = per_call(ets.eval, [(q,) for q in q_true], args.reps)
        rows.append(("rtb ets.eval (1 config, 4x4)", "", f"{med:.2f}", f"{p95:.2f}"))
        rate = throughput(lambda: ets.eval(qbig), args.batch, args.reps)
        rows.append((f"rtb ets.eval batch of {args.batch}", "", f"{rate / 1e6:.2f} M/s", ""))
    else:
        rows.append(("roboticstoolbox-python not installed", "", "", ""))

    print(f"Pincher, {args.n} random reachable targets, median of {args.reps} repetitions; "
          f"seed table built in {build * 1e3:.0f} ms")
    print("| what | success | median us (or rate) | p95 us |")
    print("|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
