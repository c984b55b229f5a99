"""Command line of training and evaluation (``dronetwin train`` and ``dronetwin evaluate`` run it).

    /usr/bin/python3 -m dronetwin.train train config/training/hover_ctbr.yaml --out runs/hover
    /usr/bin/python3 -m dronetwin.train evaluate models/policies/hover_ctbr.dtpolicy \\
        --config config/training/hover_ctbr.yaml --episodes 100 --record runs/hover_episodes

Exit status: 0 success, 2 bad input (a message names what is wrong), 3 an evaluation that
missed ``--require-success``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys


def _train(args):
    from . import ppo  # torch is imported only here

    overrides = {}
    if args.steps is not None:
        overrides["total_env_steps"] = args.steps
    if args.seed is not None:
        overrides["seed"] = args.seed
    if args.threads is not None:
        overrides["num_threads"] = args.threads
    summary = ppo.train(args.config, args.out, resume=args.resume, overrides=overrides,
                        progress=not args.quiet)
    ev = summary["evaluation"]
    if not args.quiet:
        print(f"trained {summary['env_steps']} env steps in {summary['wall_clock_s']:.1f} s "
              f"({summary['samples_per_s']:.0f} samples/s); evaluation over {ev['episodes']} episodes: "
              f"success {ev['success_fraction']:.2f}, return {ev['return_mean']:.2f}, "
              f"crashes {ev['crash_fraction']:.2f}")
        print(f"policy: {os.path.join(args.out, 'policy.dtpolicy')} (and policy.onnx)")
    return 0


def _evaluate(args):
    from . import policy
    from .training import evaluate, load_config  # numpy only: no torch to evaluate a policy

    if args.out and os.path.exists(args.out) and any(
            os.path.exists(f) and os.path.samefile(args.out, f) for f in (args.policy, args.config)):
        raise ValueError(f"evaluate: --out {args.out} is one of the inputs; the results go to a new file")
    if args.record:  # before the flights, not after them
        from .training import check_record_folder

        check_record_folder(args.record)
    if args.record_episodes < 1:
        raise ValueError(f"--record-episodes: expected an integer >= 1, got {args.record_episodes}")
    p = policy.load(args.policy)
    config = load_config(args.config)
    check_layout(p, config)
    # The training file's evaluation conditions (racing: from the start, the full episode), as
    # the trainer's own evaluations use them.
    result = evaluate(p.evaluate, config, episodes=args.episodes, seed=args.seed,
                      overrides=config["evaluation"]["overrides"],
                      record=args.record_episodes if args.record else 0)
    if args.record:
        from .training import write_episode_logs

        result, recorder = result
        folder = write_episode_logs(args.record, recorder, result, {
            "policy": os.path.abspath(args.policy), "config": os.path.abspath(args.config),
            "seed": args.seed})
        if not args.quiet:
            print(f"episode logs: {folder} ({recorder.count} episodes; dronetwin view {args.record})")
    text = json.dumps(result, indent=2)
    if args.out:
        policy.atomic_write_bytes(args.out, (text + "\n").encode())
    if not args.quiet:
        keep = {k: v for k, v in result.items() if not isinstance(v, list)}
        print(json.dumps(keep, indent=2))
    if args.require_success is not None and result["success_fraction"] < args.require_success:
        print(f"error: success fraction {result['success_fraction']:.3f} < {args.require_success}",
              file=sys.stderr)
        return 3
    return 0


def check_layout(p, config):
    """Refuses a policy whose observation layout or action convention differs from the env's
    (the C++ rule, policy/policy.hpp: ValueError naming the first difference)."""
    from .training import make_env

    p.require_env_match(make_env(config, num_envs=1)._env)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="dronetwin", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="Train a policy with PPO (config/training/*.yaml)")
    t.add_argument("config", help="training configuration (YAML)")
    t.add_argument("--out", "-o", required=True, help="output folder (new or empty, unless --resume)")
    t.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    t.add_argument("--steps", type=int, help="override total_env_steps")
    t.add_argument("--seed", type=int, help="override the seed")
    t.add_argument("--threads", type=int, help="override num_threads")
    t.add_argument("--quiet", "-q", action="store_true", help="no progress bar or report")
    e = sub.add_parser("evaluate", help="Evaluate a .dtpolicy file over randomised episodes")
    e.add_argument("policy", help="policy file (.dtpolicy)")
    e.add_argument("--config", "-c", required=True, help="training configuration the policy belongs to")
    e.add_argument("--episodes", type=int, default=100)
    e.add_argument("--seed", type=int, default=1_000_000)
    e.add_argument("--out", "-o", help="write the per-episode results (JSON) here")
    e.add_argument("--require-success", type=float, help="exit 3 when the success fraction is below this")
    e.add_argument("--record", metavar="DIR",
                   help="write the first episodes' flights here (a new folder; dronetwin view DIR)")
    e.add_argument("--record-episodes", type=int, default=10, metavar="K",
                   help="how many episodes --record keeps (the first K, default 10)")
    e.add_argument("--quiet", "-q", action="store_true")
    args = parser.parse_args(argv)
    try:
        return _train(args) if args.command == "train" else _evaluate(args)
    except (ValueError, OSError) as err:  # OSError: a file or folder that cannot be read or made
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
