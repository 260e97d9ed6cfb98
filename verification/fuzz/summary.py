"""The fuzz campaign's summary: ``bench/fuzz.json``'s counts, and the README's words for them.

:func:`summarize` turns the campaign's results (:func:`verification.fuzz.campaign.run_campaign`)
and its metadata into the contents of ``bench/fuzz.json``: counts per outcome category (each
with an example seed), per failure reason (:func:`reason_key`), per scene feature, the seeds
that did not pass, the refusal cross-check's verdicts (:func:`cross_check_summary`), the
Python warnings seen and the slowest scenes (seconds). :func:`fuzz_counts` writes that
summary as the README's *Fuzzing* block (``bench/readme.py`` puts it there).
"""

from __future__ import annotations

import re

import numpy as np

from ..refusal import CONFIRMED, FALSE_REFUSAL, STATUSES
from .checks import CATEGORIES, GOOD
from .scenes import FEATURES


def reason_key(result: dict) -> str:
    """A failure's reason without the names and numbers of its scene: the reason code, or
    the refusal's words."""
    detail = result["detail"]
    if detail.startswith("bad_input: "):
        # A name is quoted; it may hold quotes itself ('Cup''), so it ends at the quote
        # that a space, a punctuation mark or the end of the line follows.
        words = re.sub(r"(?<!\w)'.*?'(?=[\s;,.:)]|$)", "'…'", detail[len("bad_input: "):])
        words = re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "#", words)
        return "bad_input: " + words.split(";")[0]
    return detail.split(":")[0]


def cross_check_summary(results: list) -> dict:
    """The cross-check's part of fuzz.json: ``refusals_cross_checked`` (refused targets the
    cross-check decided: confirmed or contradicted), ``false_refusals`` (contradicted),
    ``refusals_not_decided`` (inconclusive or unchecked), ``cross_check_seconds`` (the
    cross-check's wall time over every scene, rebuilding the problem included), and per
    reason the counts of each
    verdict with the check's median and largest time (seconds), what decided them
    (``by_method``: ``ik`` no valid goal state, ``ompl``, ``skin``, ``bones``) and an
    example seed of each verdict;
    ``false_refusal_list`` gives each contradicted refusal (seed, target, reason, why)."""
    per: dict = {}
    false = []
    for r in results:
        for c in r.get("cross_check", ()):
            entry = per.setdefault(c["reason"], {"refusals": 0, **{k: 0 for k in STATUSES},
                                                 "by_method": {}, "examples": {},
                                                 "seconds": []})
            entry["refusals"] += 1
            entry[c["status"]] += 1
            entry["examples"].setdefault(c["status"], {"seed": r["seed"], "target": c["target"],
                                                       "detail": c["detail"]})
            if c["status"] in (CONFIRMED, FALSE_REFUSAL):
                entry["by_method"][c["method"]] = entry["by_method"].get(c["method"], 0) + 1
            entry["seconds"].append(c["seconds"])
            if c["status"] == FALSE_REFUSAL:
                false.append({"seed": r["seed"], "target": c["target"], "reason": c["reason"],
                              "detail": c["detail"]})
    for entry in per.values():
        t = entry.pop("seconds")
        entry["seconds_median"] = round(float(np.median(t)), 3)
        entry["seconds_max"] = round(float(np.max(t)), 3)
    decided = sum(e[CONFIRMED] + e[FALSE_REFUSAL] for e in per.values())
    spent = [r["timings"]["cross_check"] for r in results if "cross_check" in r.get("timings", {})]
    return {"refusals_cross_checked": decided, "false_refusals": len(false),
            "refusals_not_decided": sum(e["refusals"] for e in per.values()) - decided,
            "cross_check_seconds": round(float(np.sum(spent)), 1) if spent else 0.0,
            "cross_check": dict(sorted(per.items(), key=lambda kv: -kv[1]["refusals"])),
            "false_refusal_list": false}


def summarize(results: list, meta: dict) -> dict:
    """The contents of fuzz.json: counts per category (each with an example seed and its
    one-line description), per failure reason, per feature; every non-passing seed."""
    categories = {}
    for name, meaning in CATEGORIES.items():
        hits = [r for r in results if r["category"] == name]
        categories[name] = {"count": len(hits), "meaning": meaning}
        if hits:
            categories[name].update(example_seed=hits[0]["seed"], example=hits[0]["detail"])
    reasons: dict = {}
    for r in results:
        if r["category"] == "failure_with_reason":
            key = reason_key(r)
            entry = reasons.setdefault(key, {"count": 0, "example_seed": r["seed"],
                                             "example": r["detail"]})
            entry["count"] += 1
    features = {}
    for f in FEATURES:
        hits = [r for r in results if f in r["features"]]
        features[f] = {"scenes": len(hits), **{c: n for c in CATEGORIES
                                               if (n := sum(r["category"] == c for r in hits))}}
    bad = [{"seed": r["seed"], "category": r["category"], "detail": r["detail"]}
           for r in results if r["category"] not in GOOD]
    times = [r["time_s"] for r in results if r.get("time_s") is not None]
    warned: dict = {}
    for r in results:
        for w in r.get("warnings", ()):
            entry = warned.setdefault(w, {"scenes": 0, "example_seed": r["seed"]})
            entry["scenes"] += 1
    slowest = sorted((r for r in results if r.get("time_s") is not None),
                     key=lambda r: -r["time_s"])[:5]
    cross = cross_check_summary(results)
    body: dict = {}
    for r in results:
        for outcome in r.get("body", ()):
            body[outcome] = body.get(outcome, 0) + 1
    return {**meta, "scenes": len(results), "body": dict(sorted(body.items())),
            "passed": sum(r["category"] in GOOD for r in results),
            "seconds_per_scene_median": round(float(np.median(times)), 3) if times else None,
            "categories": categories,
            "failure_reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1]["count"])),
            "features": features, "not_passing": bad, **cross,
            "python_warnings": dict(sorted(warned.items(), key=lambda kv: -kv[1]["scenes"])),
            "slowest": [{"seed": r["seed"], "time_s": r["time_s"], "category": r["category"],
                         "rig": r["rig"], "task": r["task"]} for r in slowest]}


def fuzz_counts(f: dict) -> str:
    """The campaign's outcomes from ``bench/fuzz.json``: every category (a bug category
    too, at 0), the seeds that did not pass, the most frequent failure reasons, and the
    refusal cross-check's counts (:func:`cross_check_counts`)."""
    last = f["seed0"] + f["scenes"] - 1
    lines = [f"From `bench/fuzz.json`: {f['scenes']:,} scenes (seeds {f['seed0']}–{last}; Reach "
             f"{f['reach_version']}" + (f" at {f['reach_commit']}" if f.get("reach_commit") else "")
             + f", bpy {f['blender_version']}, {f['jobs']} worker process"
             + ("es" if f["jobs"] != 1 else "") + ", "
             f"{f['wall_time_s'] / 60:.0f} min, median {f['seconds_per_scene_median']:.2f} s a "
             f"scene): **{f['passed']:,} passed** ({100 * f['passed'] / f['scenes']:.2f} %).",
             "", "| outcome | scenes | example seed |", "|---|---:|---|"]
    for name, c in f["categories"].items():
        lines.append(f"| `{name}` | {c['count']:,} | {c.get('example_seed', '')} |")
    if f["not_passing"]:
        lines += ["", "Not passing: " + "; ".join(
            f"seed {r['seed']} (`{r['category']}`: {r['detail']})" for r in f["not_passing"])
            + "."]
    reasons = sorted(f["failure_reasons"].items(), key=lambda kv: (-kv[1]["count"], kv[0]))
    lines += ["", "The most frequent failure reasons: " + "; ".join(
        f"`{k}` {v['count']:,} (seed {v['example_seed']})" for k, v in reasons[:8]) + "."]
    lines += ["", cross_check_counts(f)]
    return "\n".join(lines)


def cross_check_counts(f: dict) -> str:
    """The refusal cross-check's counts from ``bench/fuzz.json``: refusals decided
    (confirmed or contradicted) and false refusals, per reason with the check's median and
    largest time; a campaign from before the cross-check says so."""
    if "refusals_cross_checked" not in f:
        return ("Refusals cross-checked: none — this campaign predates the cross-check "
                "(`verification/refusal.py`), so its failures with a reason are unchecked "
                "claims; `false_refusals` not counted.")
    per = f.get("cross_check", {})
    parts = [f"`{reason}` {e['confirmed']:,} confirmed, {e['false_refusal']:,} false, "
             f"{e['inconclusive'] + e['unchecked']:,} undecided "
             f"({e['seconds_median']:.2f}/{e['seconds_max']:.2f} s)"
             for reason, e in per.items()]
    seeds = "".join(f"; seed {x['seed']} `{x['reason']}` ('{x['target']}')"
                    for x in f.get("false_refusal_list", [])[:10])
    return (f"Refusals cross-checked (`verification/refusal.py`, OMPL "
            f"{f.get('cross_check_budget_s', 10):g} s where a goal region exists): "
            f"**{f['refusals_cross_checked']:,} decided**, **{f['false_refusals']:,} false "
            f"refusals**{seeds}, {f.get('refusals_not_decided', 0):,} undecided (a chase's "
            "pursuit, a later leg of a sequence, a target in the body, a start the core's "
            f"test refuses); {f.get('cross_check_seconds', 0):,.0f} s of cross-check in all. "
            "Per refused target and reason (median/largest seconds of the check): "
            + "; ".join(parts) + ".")
