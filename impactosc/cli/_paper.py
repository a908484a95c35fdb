"""``impactosc paper``: recompute the paper's Fig. 6-8 and the report."""

from __future__ import annotations

from ._common import check_output_dir


def add_parser(sub) -> None:
    pp = sub.add_parser("paper", help="recompute the paper's Fig. 6-8 and the report",
                        description="Fig. 6 (run-out law), Fig. 7 and 8 (average flange force vs pack diameter) with "
                                    "the event-driven solver and the paper's RK4 baseline, alternative parameter "
                                    "sets, timings; writes DIR/paper_reproduction.md, DIR/*.csv, DIR/figures/*.png.")
    pp.add_argument("--quick", action="store_true", help="coarse grid (5 diameters) and a 10 ms average: ~30 s")
    pp.add_argument("--study", action="store_true",
                    help="instead, the study of Fig. 4's four trends (contact observables as the AE sensor saw them, "
                         "candidate models, a parameter search): DIR/fig4_study.md, .json, .csv, figures")
    pp.add_argument("--out", default="reports", metavar="DIR", help="output directory (default reports)")
    pp.add_argument("--serial", action="store_true", help="run the sweeps in this process instead of a pool")
    pp.add_argument("--no-progress", action="store_true", help="no progress bars")
    pp.set_defaults(handler=run)


def run(args) -> int:
    from ..paper import reproduce

    check_output_dir("--out", args.out)
    if args.study:
        return _study(args)

    s = reproduce(args.out, quick=args.quick, executor="serial" if args.serial else None,
                  progress=not args.no_progress)
    ed, cost = s["event_driven"], s["rk4_default_step"]
    rk = s["rk4_figure_step"]["consistent"]
    print(f"Fig. 6-8 recomputed ({'quick' if args.quick else 'full'}), written to {args.out}/paper_reproduction.md, "
          f"{args.out}/*.csv and {args.out}/figures/*.png")
    print(f"  paper's parameters: {ed['fig7']['impacts_total'] + ed['fig8']['impacts_total']} flange contacts, "
          f"max mean flange force {max(ed['fig7']['max_mean_force_N'], ed['fig8']['max_mean_force_N']):g} N "
          f"(event-driven); RK4 + sign(): {rk['fig7_max_force_N']:g} N")
    print(f"  event-driven Fig. 7 grid ({ed['fig7_points']} points): {ed['fig7_wall_s']:.1f} s; RK4 at the figure "
          f"step: {rk['fig7_wall_s']:.2f} s; RK4 at the default step (extrapolated): "
          f"{cost['fig7_full_extrapolated_s']:.0f} s")
    for name, info in s["alternatives"].items():
        t = info["trends"]
        print(f"  alternative {name}: {info['impacts_total']} contacts, max {t['max_force']:.3g} N, "
              f"up with speed: {t['up_with_speed']}, down with T sin: {t['down_with_t_sin']}, "
              f"0.1/0.7 ratio {t['ratio_01_07']:.3g}")
    return 0




def _study(args) -> int:
    from ..paper import study

    s = study(args.out, quick=args.quick, executor="serial" if args.serial else None, progress=not args.no_progress)
    best = s["best"]
    held = [k for k, v in best["trends"].items() if v]
    print(f"Fig. 4 study ({'quick' if args.quick else 'full'}), written to {args.out}/fig4_study.md, "
          f"{args.out}/fig4_study.json, {args.out}/fig4_study.csv and {args.out}/figures/fig4_study_*.png")
    print(f"  best: {best['model']} with {best['observable']}: {len(held)} of 4 trends ({', '.join(held) or 'none'})")
    print(f"  lead scan: {s['lead_scan']['all_four']} of {s['lead_scan']['points']} points hold all four; "
          f"{s['wall_s']:.0f} s")
    return 0
