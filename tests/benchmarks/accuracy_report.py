"""Tables, the markdown page and the plot of the accuracy benchmark (bench_accuracy.py),
from one or more results.json."""
from __future__ import annotations

import io
import json
import statistics
from pathlib import Path

PAPER_MAX_CM = 1.5          # Wang 2018, section 8.3: max landmark distance to hand grading
BASELINES = ("unchanged", "scaled")
PAGE = "accuracy_results.md"
PLOT = "img/accuracy_cases.png"


# ----------------------------------------------------------------------------- data

def load_results(paths: list[Path]) -> dict:
    """Merge results.json files: cases keyed by (garment, body), later files win."""
    metas, cases = [], {}
    for p in paths:
        d = json.loads(Path(p).read_text())
        metas.append({**d.get("meta", {}), "file": str(p)})
        for c in d.get("cases", []):
            cases[(c["garment"], c["body"])] = c
    return {"metas": metas, "cases": [cases[k] for k in sorted(cases)]}


def method_names(res: dict) -> list[str]:
    """Grading methods in run order, then the two baselines."""
    names = []
    for m in res["metas"]:
        names += [x for x in m.get("methods", []) if x not in names]
    for c in res["cases"]:
        names += [x for x in c.get("methods", {}) if x not in names and x not in BASELINES]
    return names + list(BASELINES)


def graders(res: dict) -> list[str]:
    return [m for m in method_names(res) if m not in BASELINES]


def entry(case: dict, method: str) -> dict:
    e = case.get("methods", {}).get(method)
    if e is None:
        return case.get("error") or {"ok": False, "error": "not run"}
    return e


def _ok(e: dict) -> bool:
    return bool(e.get("ok")) and e.get("max_cm") is not None


def _f(x, nd: int = 2) -> str:
    return "-" if x is None else f"{x:.{nd}f}"


def landmark_cell(e: dict) -> str:
    return f"{e['max_cm']:.2f} / {e['mean_cm']:.2f}" if _ok(e) else "failed"


def key_level(case: dict) -> str:
    """The level the garment really encloses: the girth proportional scaling uses."""
    from seamfit.pattern.scale import girth_for_garment
    return girth_for_garment(case.get("garment_type"))


def key_ease_error(case: dict, e: dict) -> float | None:
    """Ease error (cm) at the garment's key level; None when not measured there."""
    return ((e.get("ease_error") or {}).get("levels") or {}).get(key_level(case))


def ease_cell(case: dict, e: dict) -> str:
    if not e.get("ok"):
        return "failed"
    v = key_ease_error(case, e)
    return "n/m" if v is None else f"{v:.1f}"      # n/m: not measured


def seconds_cell(e: dict) -> str:
    return f"{e['seconds']:.1f}" if e.get("ok") and e.get("seconds") is not None else "-"


# ----------------------------------------------------------------------------- tables

def console_table(res: dict) -> list[str]:
    """Fixed-width text: per garment and body, max / mean landmark cm per method, ease error
    (max over bust / waist / hip, cm) per method and seconds per grading method."""
    names, gr = method_names(res), graders(res)
    head = (f"{'garment':<17} {'body':<10} " + " ".join(f"{m[:13]:>13}" for m in names) + "  | ease err "
            + "/".join(m[:5] for m in names) + " | s " + "/".join(m[:5] for m in gr))
    lines = ["landmark error max / mean cm after per-panel rigid alignment; ease error cm at the garment's "
             "key level (bust: tops, waist: circle skirts, hip: others)", head]
    garment = None
    for c in res["cases"]:
        if c["garment"] != garment and garment is not None:
            lines.append("")
        garment = c["garment"]
        es = [entry(c, m) for m in names]
        lines.append(f"{c['garment']:<17} {c['body']:<10} " + " ".join(f"{landmark_cell(e):>13}" for e in es)
                     + "  | " + "/".join(ease_cell(c, e) for e in es)
                     + " | " + "/".join(seconds_cell(entry(c, m)) for m in gr))
    for c in res["cases"]:
        for m in names:
            e = entry(c, m)
            if not e.get("ok"):
                lines.append(f"  {c['garment']}/{c['body']} {m}: {e.get('error')}")
    return lines


def summary(res: dict) -> list[str]:
    names = method_names(res)
    n = len(res["cases"])
    out = ["| method | scored | failed | max cm (worst case) | median of case max cm | mean landmark cm "
           f"| cases < {PAPER_MAX_CM} cm | better than unchanged | better than scaled | median ease error cm "
           "| median seconds | > 0.3 cm worse than unchanged | stitches > 2 mm beyond designed ease |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m in names:
        es = [(c, entry(c, m)) for c in res["cases"]]
        ok = [(c, e) for c, e in es if _ok(e)]
        mx = [e["max_cm"] for _, e in ok]
        better = {b: sum(1 for c, e in ok if _ok(entry(c, b)) and e["max_cm"] < entry(c, b)["max_cm"])
                  for b in BASELINES}
        ease = [v for v in (key_ease_error(c, e) for c, e in ok) if v is not None]
        secs = [e["seconds"] for _, e in ok if e.get("seconds") is not None]
        worst = max(ok, key=lambda ce: ce[1]["max_cm"], default=None)
        lost = ("-" if m == "unchanged" else
                str(sum(1 for c, e in ok if _ok(entry(c, "unchanged")) and e["max_cm"] > entry(c, "unchanged")["max_cm"] + 0.3)))
        excess = [e["max_seam_excess_mm"] for _, e in ok if e.get("max_seam_excess_mm") is not None]
        seams = f"{sum(v > 2.0 for v in excess)} / {len(excess)}" if excess else "-"
        out.append(f"| {m} | {len(ok)} | {n - len(ok)} | "
                   + (f"{worst[1]['max_cm']:.2f} ({worst[0]['garment']}/{worst[0]['body']})" if worst else "-")
                   + f" | {_f(statistics.median(mx) if mx else None)} | "
                   f"{_f(statistics.mean(e['mean_cm'] for _, e in ok) if ok else None)} | "
                   f"{sum(v < PAPER_MAX_CM for v in mx)} / {len(ok)} | "
                   + " | ".join("-" if m == b else f"{better[b]} / {len(ok)}" for b in BASELINES)
                   + f" | {_f(statistics.median(ease) if ease else None, 1)}"
                   + f" | {_f(statistics.median(secs) if secs else None, 1)} | {lost} | {seams} |")
    return out


def family_table(res: dict) -> list[str]:
    """Per garment family: median and worst of the per-case max landmark error per method,
    and the median key-level ease error (the issue's per-family bar: the grading's median
    at most 0.2 cm above scaling's)."""
    names = method_names(res)
    moved = [m for m in names if m != "unchanged"]       # the unchanged pattern captures 0 by definition
    out = ["| garment | cases | " + " | ".join(f"{m} median / worst cm" for m in names)
           + " | median ease error cm (" + " / ".join(names) + ") | median change captured ("
           + " / ".join(moved) + ") |",
           "|---|---:|" + "---:|" * len(names) + "---|---|"]
    for garment in dict.fromkeys(c["garment"] for c in res["cases"]):
        rows = [c for c in res["cases"] if c["garment"] == garment]
        cells, ease, captured = [], [], []
        for m in names:
            mx = [entry(c, m)["max_cm"] for c in rows if _ok(entry(c, m))]
            cells.append(f"{statistics.median(mx):.2f} / {max(mx):.2f}" if mx else "failed")
            ev = [v for v in (key_ease_error(c, entry(c, m)) for c in rows if _ok(entry(c, m))) if v is not None]
            ease.append(_f(statistics.median(ev) if ev else None, 1))
            if m in moved:
                cells_m = []
                for get in (lambda e: e.get("change_captured"),
                            lambda e: (e.get("change_captured_uv") or [None, None])[0],
                            lambda e: (e.get("change_captured_uv") or [None, None])[1]):
                    cv = [v for v in (get(entry(c, m)) for c in rows if _ok(entry(c, m))) if v is not None]
                    cells_m.append(_f(statistics.median(cv) if cv else None, 2))
                captured.append(" ".join([cells_m[0], f"({cells_m[1]}, {cells_m[2]})"]))
        out.append(f"| {garment} | {len(rows)} | " + " | ".join(cells) + " | " + " / ".join(ease) + " | "
                   + " / ".join(captured) + " |")
    return out


def garment_tables(res: dict) -> list[str]:
    names, gr = method_names(res), graders(res)
    out = []
    for garment in dict.fromkeys(c["garment"] for c in res["cases"]):
        rows = [c for c in res["cases"] if c["garment"] == garment]
        out += [f"### {garment}", "",
                "| body | " + " | ".join(f"{m} max / mean cm" for m in names)
                + " | ease error cm (" + " / ".join(names) + ") | seconds (" + " / ".join(gr + ["scaled"]) + ") |",
                "|---|" + "---:|" * len(names) + "---|---|"]
        for c in rows:
            es = [entry(c, m) for m in names]
            out.append(f"| {c['body']} | " + " | ".join(landmark_cell(e) for e in es) + " | "
                       + " / ".join(ease_cell(c, e) for e in es) + " | "
                       + " / ".join(seconds_cell(entry(c, m)) for m in gr + ["scaled"]) + " |")
        out.append("")
    return out


def ease_detail(res: dict) -> list[str]:
    names = method_names(res)
    out = ["| garment | body | base ease cm (bust / waist / hip) | "
           + " | ".join(f"{m} ease cm" for m in names) + " |", "|---|---|---|" + "---|" * len(names)]
    lv = ("bust", "waist", "hip")
    fmt = lambda d: " / ".join(_f((d or {}).get(k), 1) for k in lv)  # noqa: E731
    for c in res["cases"]:
        cells = []
        for m in names:
            e = entry(c, m)
            err = (e.get("ease_error") or {}).get("max_cm")
            cells.append(fmt(e.get("ease_cm")) + (f" (max error {err:.1f})" if err is not None else "")
                         if e.get("ease_cm") else (e.get("ease_note") or "-"))
        out.append(f"| {c['garment']} | {c['body']} | {fmt(c.get('base_ease_cm'))} | " + " | ".join(cells) + " |")
    return out


def _level_medians(entries, key: str) -> list[str]:
    cells = []
    for k in ("bust", "waist", "hip"):
        v = [x for x in (((e.get(key) or {}).get("levels") or {}).get(k) for e in entries) if x is not None]
        cells.append(f"{statistics.median(v):.2f} ({len(v)})" if v else "-")
    return cells


def ease_levels(res: dict, key: str = "ease_error") -> list[str]:
    """Median ease error per level over the cases whose garment goes around it there:
    against the base garment's ease (``ease_error``) or the draft's (``ease_vs_draft``); the
    first table has the drafts' own row."""
    lv = ("bust", "waist", "hip")
    out = ["| method | " + " | ".join(f"{k} cm (cases)" for k in lv) + " |", "|---|" + "---:|" * len(lv)]
    for m in method_names(res):
        ents = [entry(c, m) for c in res["cases"] if _ok(entry(c, m))]
        out.append(f"| {m} | " + " | ".join(_level_medians(ents, key)) + " |")
    drafts = [c["draft"] for c in res["cases"] if c.get("draft", {}).get("ease_cm")]
    if key == "ease_error" and drafts:
        out.append("| the drafts themselves | " + " | ".join(_level_medians(drafts, key)) + " |")
    return out


def ease_against_drafts(res: dict) -> list[str]:
    """The ease error against the draft's own ease on the target (the draft put on the base mesh
    and draped from the same start), where the run measured it."""
    n = sum(1 for c in res["cases"] if c.get("draft", {}).get("ease_cm"))
    if not n:
        return []
    return ["The drafting systems do not hold the base garment's ease: their own row above is "
            "each draft draped on its body, scored the same way. Against the ease each draft "
            f"gives its body ({n} cases where the draft's panels have the base's edges, so it "
            "can be put on the base mesh): |ease on the target - the draft's ease on the target|, "
            "median per level:", "", *ease_levels(res, "ease_vs_draft"), ""]


def ease_flags(res: dict) -> list[str]:
    """Where each method (and each draft) came out tighter than the base garment on the base
    body, by the rule `seamfit grade` warns with (``seamfit.opt.fit.tighter_levels``)."""
    from seamfit.opt.fit import tighter_levels

    def flagged(e: dict, base: dict) -> list[str]:
        return tighter_levels(base, e.get("ease_cm") or {})

    rows = [(m, [(c, flagged(entry(c, m), c.get("base_ease_cm") or {})) for c in res["cases"] if _ok(entry(c, m))])
            for m in method_names(res)]
    rows.append(("the drafts themselves", [(c, flagged(c["draft"], c.get("base_ease_cm") or {}))
                                           for c in res["cases"] if c.get("draft", {}).get("ease_cm")]))
    out = ["| method | cases flagged | where (levels) |", "|---|---:|---|"]
    for m, cases in rows:
        hits = [f"{c['garment']} {c['body']} ({', '.join(lv)})" for c, lv in cases if lv]
        out.append(f"| {m} | {len(hits)} of {len(cases)} | {'; '.join(hits) or '-'} |")
    return ["Levels where the garment on the target keeps under half the base garment's ease and at "
            "least 1 cm less (`seamfit.opt.fit.tighter_levels`, the rule `seamfit grade` warns with: "
            "tighter there than the base pattern on its own body):", "", *out, ""]


def failures(res: dict) -> list[str]:
    out = []
    for c in res["cases"]:
        for m in method_names(res):
            e = entry(c, m)
            if not e.get("ok"):
                out.append(f"* {c['garment']} / {c['body']}, {m}: `{e.get('error')}`")
    return out or ["None."]


def worst_cases(res: dict, method: str, k: int = 5) -> list[str]:
    """Facts about the k cases with the largest max landmark error of ``method``."""
    ok = [c for c in res["cases"] if _ok(entry(c, method))]
    ok.sort(key=lambda c: -entry(c, method)["max_cm"])
    out = []
    for c in ok[:k]:
        e, u, s = entry(c, method), entry(c, "unchanged"), entry(c, "scaled")
        panel, lm = e["worst"] if e.get("worst") else ("?", "?")
        pm = sorted(((p["max_cm"], n) for n, p in e["panels"].items()), reverse=True)
        bits = [f"**{c['garment']} / {c['body']}**: {method} {e['max_cm']:.2f} cm at {panel}: {lm} "
                f"(unchanged {_f(u.get('max_cm'))}, scaled {_f(s.get('max_cm'))} cm); panels "
                + ", ".join(f"{n} {v:.2f}" for v, n in pm[:4]) + "."]
        if e.get("order_matched"):
            bits.append(f"The drafting rules changed the topology (order-matched panels: "
                        f"{', '.join(e['order_matched'])}): the truth has a different set of darts or edges, "
                        "which grading never adds or removes.")
        if e.get("converged") is False:
            bits.append(f"The optimization stopped at its budget ({e.get('message')}, "
                        f"{e.get('outer_iterations')} iterations).")
        if (e.get("ease_error") or {}).get("levels"):
            lv = e["ease_error"]["levels"]
            bits.append("Ease error " + ", ".join(f"{k_} {v:.1f}" for k_, v in lv.items()) + " cm.")
        g = s.get("ratios") if s.get("ok") else None
        if g:
            bits.append(f"Girth ratio ({g['girth']}) {g['sx']:.3f}, height ratio {g['sy']:.3f}.")
        out.append("* " + " ".join(bits))
    return out or ["No case was scored."]


# ----------------------------------------------------------------------------- page

def _blas(mc: dict) -> str:
    """', OpenBLAS kernels numpy X / SciPy Y' where the run recorded them."""
    b = mc.get("blas") or {}
    if not (b.get("numpy") or b.get("scipy")):
        return ""
    return f", OpenBLAS kernels numpy {b.get('numpy', '?')} / SciPy {b.get('scipy', '?')}"


def provenance(res: dict) -> list[str]:
    out = []
    for m in res["metas"]:
        mc = m.get("machine", {})
        out.append(f"* `{m['file']}`: {'**subset** of the cases' if m.get('subset') else 'all cases'}, "
                   f"methods {', '.join(m.get('methods', []))}; machine {mc.get('cpu', '?')}, {mc.get('cores', '?')} "
                   f"cores, Python {mc.get('python', '?')}{_blas(mc)}; jobs {m.get('jobs')} x "
                   f"{m.get('threads_per_job')} threads; commit {m.get('commit')}"
                   + (" (native/ modified)" if m.get("native_modified") else "")
                   + (f", sources {m['source_digest']}" if m.get("source_digest") else "")
                   + f"; started {m.get('started')}, "
                   f"wall {_f(m.get('wall_seconds'), 0)} s.")
        out.append(f"  Command: `{m.get('command')}`")
    gs = {json.dumps(c.get("grade_settings"), sort_keys=True) for c in res["cases"] if c.get("grade_settings")}
    for g in sorted(gs):
        out.append(f"* Grade settings (overrides of `GradeSettings` defaults): `{g}`")
    return out


DISCUSSION = """\
Why the worst cases are where they are, and what the numbers can and cannot say:

* **The truth is another set of drafting rules, not a fit.** The grading keeps how the base
  garment fits (ease, drape, stretch; the objective of the paper's Eq. 10-14); FreeSewing and
  GarmentCode re-draft from the measurements with their own formulas (dart intake from the
  waist/hip difference, ease added as a fixed amount or a percentage, armhole and crotch curves
  from fixed ratios). Where those rules put the change in a different place than the body does
  (a deeper dart instead of a wider side seam), a correct fit-preserving grading still differs from
  the draft. The paper's 1.5 cm was measured against *hand* grading of the same kind, which is
  closer to fit preservation than to re-drafting.
* **Large size jumps and other shapes** (size16, apple, the man) move landmarks most, so every
  method's error grows with the distance from the base body; the proportional baseline is then
  also far off, because girth and height ratios do not say where the extra girth goes.
* **Topology changes.** For apple and the man, GarmentCode drops darts and edges; the metric then
  matches the remaining landmarks in outline order. The graded pattern keeps every dart of the base,
  so a dart whose intake the rules set to zero shows as an error at its legs and tip.
* **Men from a women's base** (cross-gender grading) is the hardest case for all methods: the
  drape on the base body cannot tell the solver what a men's block does with the hip and crotch.
* **Circle skirts** are fitted only at the waist; their hem landmarks sit 30-60 cm from the waist,
  so a small angle difference of the flare shows as centimetres at the hem, while the ease (at the
  waist) can be right.
* **Ease is taken as a tape takes it.** At the body's bust / waist / hip levels, around the
  torso under the arms (the cloth nearest the torso, not the hull around both sleeves: a
  t-shirt's bust ease read 35-49 cm that way), and only where the garment's section goes around
  the torso (a bodice block whose back ends above the waist has no waist ease).
* **Budget.** A run with coarse settings (few outer iterations, 3-4 cm mesh, 5 mm SDF) stops
  before convergence; `converged` and the iteration count are kept per case in results.json.
"""


def markdown(res: dict, title_note: str | None, plot_rel: str, notes: str | None = None) -> str:
    gr = graders(res)
    lead = gr[0] if gr else "unchanged"
    lines = ["# Grading accuracy against the drafting systems' own patterns", ""]
    if title_note:
        lines += [f"**{title_note}**", ""]
    lines += [
        "Generated by `tests/benchmarks/bench_accuracy.py report` from:", "", *provenance(res), "",
        "Each case grades the base pattern (size06, drafted for `women_size06`) to one other body and "
        "compares the result with the pattern the same drafting system made for that body. Metric "
        "(`seamfit.pattern.compare.landmark_errors`): per panel, the least-squares rigid alignment over "
        "the landmarks both patterns have (by name; GarmentCode's positional ids in outline order where "
        "the rules dropped a feature), then landmark distances in cm; **max** is the largest over all "
        "panels, **mean** the mean over matched points. Baselines: **unchanged** (the base pattern as it "
        "is, `baseline_errors`) and **scaled** (`seamfit.pattern.scale.proportional_scale`: each panel "
        "scaled about its bounding-box centre, widths by the target/base girth ratio - bust for tops, "
        "waist for circle skirts, hip otherwise - and lengths by the stature ratio, curves refitted). "
        "**Ease error**: |ease on the target - ease of the base pattern on the base body| (garment tape "
        "girth minus body tape girth, `seamfit.opt.fit.ease_report`, the bust's over the bust points) at the level the garment encloses "
        "(bust for tops, waist for circle skirts, hip otherwise; every level, and the max over them, "
        "under *Ease per level*); for the baselines the pattern is draped on the target from the "
        "same transferred start as the grading (`n/m`: not measured). **Seconds**: the grading's "
        "`seconds_total` (mesh, SDFs, base drape - cached on disk after the first case of a garment -, "
        "transfer, optimization, refit); for scaling, the scaling and curve refit only.",
        "", f"The paper (section 8.3) reports a max landmark difference under {PAPER_MAX_CM} cm against "
        "hand grading.", "", "## Summary", "", *summary(res), "",
        "Median ease error per level, over the cases whose garment goes around that level:", "",
        *ease_levels(res), "",
        *ease_against_drafts(res),
        *ease_flags(res),
        f"![max landmark error per case]({plot_rel})", "",
        "## Per garment family", "", *family_table(res), "",
        "*Change captured* (`seamfit.pattern.compare.change_captured`): the least-squares factor c "
        "in result - base = c (draft - base) over every landmark, each panel rigidly aligned onto "
        "the draft's: 1 is the drafted change in full, below 1 under-graded, 0 the base unchanged; in "
        "brackets the same across the grain (u, widths) and along it (v, lengths).", "",
        "## Per garment and body", "", *garment_tables(res),
        "## Ease per level", "", *ease_detail(res), "",
        "## Failures", "", *failures(res), "",
        f"## The worst cases ({lead})", "", *worst_cases(res, lead), "",
        "## Discussion", "", DISCUSSION,
    ]
    if notes:
        lines += ["## Notes on this run", "", notes.strip(), ""]
    return "\n".join(lines) + "\n"


def plot(res: dict) -> bytes:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = method_names(res)
    cases = res["cases"]
    labels = [f"{c['garment']}\n{c['body']}" for c in cases]
    fig, axes = plt.subplots(2, 1, figsize=(max(6.0, 0.55 * len(cases) + 2), 7), sharex=True)
    marks = {"unchanged": ("s", "0.5"), "scaled": ("^", "tab:orange")}
    others = iter(["tab:blue", "tab:green", "tab:red", "tab:purple"])
    width = 0.8 / max(len(names), 1)
    for j, m in enumerate(names):
        mk, col = marks.get(m, ("o", next(others, "k")))
        xs = [i + (j - (len(names) - 1) / 2) * width for i in range(len(cases))]
        es = [entry(c, m) for c in cases]
        good = [(x, e["max_cm"]) for x, e in zip(xs, es) if _ok(e)]
        if good:
            axes[0].scatter(*zip(*good), marker=mk, color=col, label=m, zorder=3)
        fail = [x for x, e in zip(xs, es) if not _ok(e)]
        if fail and m not in BASELINES:
            axes[0].scatter(fail, [0.0] * len(fail), marker="x", color=col, zorder=3, label=f"{m} failed")
        ez = [(x, v) for x, c, e in zip(xs, cases, es)
              if e.get("ok") and (v := key_ease_error(c, e)) is not None]
        if ez:
            axes[1].scatter(*zip(*ez), marker=mk, color=col, label=m, zorder=3)
    axes[0].axhline(PAPER_MAX_CM, color="k", ls="--", lw=1, label=f"paper, {PAPER_MAX_CM} cm")
    axes[0].set_ylabel("max landmark distance (cm)")
    axes[0].legend(fontsize=8, ncol=4, loc="upper left")
    axes[1].set_ylabel("ease error at the key\nlevel (cm)")
    axes[1].legend(fontsize=8, ncol=4, loc="upper left")
    for ax in axes:
        ax.grid(axis="y", alpha=0.3)
        ax.set_ylim(0, 1.35 * ax.get_ylim()[1])      # headroom for the legend
    axes[1].set_xticks(range(len(cases)))
    axes[1].set_xticklabels(labels, fontsize=7, rotation=90 if len(cases) > 8 else 0)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def write_report(res: dict, docs: Path, title_note: str | None = None, notes: str | None = None) -> list[Path]:
    from seamfit.fileio import atomic_write_bytes, atomic_write_text
    png = atomic_write_bytes(docs / PLOT, plot(res))
    md = atomic_write_text(docs / PAGE, markdown(res, title_note, PLOT, notes))
    return [Path(md), Path(png)]
