"""Reproduce the thesis's published cases and compare them side by side.

The published numbers (tables 4.1-4.25 of the thesis, shipped as
``gaocvx/data/thesis_cases.json``) are set beside the convex ground truth of
the same scene on the same mesh, with the relative differences, and flagged
where they disagree by more than the agreement reference-cases.md reports.

Run ``gaocvx report thesis --output docs/thesis-reproduction.md``.
"""

from __future__ import annotations

import json
from importlib import resources

from .scene import Scene
from .solve import solve

__all__ = ["thesis_cases", "thesis_scene", "thesis_rows", "thesis_markdown"]

# Relative differences above which a published number is flagged.
FLAG_W = 6e-3
FLAG_E = 1.5e-3


def thesis_cases() -> dict:
    """The published cases: ``{"common": {...}, "cases": [...]}``."""
    text = resources.files("gaocvx").joinpath("data/thesis_cases.json").read_text()
    return json.loads(text)


def thesis_scene(case: dict, model: str, mu: float | None = None, common: dict | None = None) -> Scene:
    """The scene of one published case for ``model`` ("gao" or "euler-bernoulli")."""
    common = common or thesis_cases()["common"]
    sc = case["scene"]
    beam = {k: common[k] for k in ("length", "E", "nu", "half_thickness", "width")}
    beam.update(model=model, supports=sc["supports"])
    if mu is not None:
        beam["mu"] = mu
    load = {"axial": sc["load"]["axial"], "points": sc["load"]["points"]}
    if sc["load"]["q"] is not None:
        load["q"] = sc["load"]["q"]
    data = {"beam": beam, "load": load, "mesh": {"elements": common["elements"]}}
    if "foundation" in sc:
        data["foundation"] = dict(sc["foundation"])
    return Scene.from_dict(data)


def _rel(a, b):
    return (a - b) / abs(b) if b else float("nan")


def _cvm_scene(scene: Scene) -> Scene:
    """The scene solved the thesis's way: CVM, automatic transform, piecewise-linear control."""
    return scene.with_overrides({"solve.method": "cvm", "solve.control": "P1",
                                 "solve.transform": "auto"})


def thesis_rows(method: str = "convex", with_cvm: bool = True) -> list[dict]:
    """One row per (case, model): published and computed extrema, energy, zone.

    For Gao cases with an axial force on supports P1, P2, P4 a second row
    with mu = 1 is added: the thesis's computations used P in place of P mu
    there (reference-cases.md).
    """
    data = thesis_cases()
    rows = []
    for case in data["cases"]:
        sc = case["scene"]
        for model in ("euler-bernoulli", "gao"):
            mus = [None]
            if model == "gao" and sc["load"]["axial"] and sc["supports"] != "P3":
                mus.append(1.0)
            for mu in mus:
                result = solve(thesis_scene(case, model, mu, data["common"]), method)
                pub = case["thesis"][model]
                row = {"table": case["table"], "model": model, "mu": mu, "status": result.status}
                for key in ("min", "max"):
                    if key in pub:
                        ours = getattr(result, key)
                        row[key] = {"published": pub[key]["w"], "ours": ours["w"],
                                    "rel": _rel(ours["w"], pub[key]["w"]),
                                    "x_published": pub[key]["x"], "x_ours": ours["x"]}
                row["energy"] = {"published": pub["energy"], "ours": result.energy,
                                 "rel": _rel(result.energy, pub["energy"])}
                if "contact_zone" in pub:
                    row["zone"] = {"published": pub["contact_zone"], "ours": result.zones}
                if with_cvm:
                    c = solve(_cvm_scene(result.scene))
                    row["cvm"] = {"status": c.status, "transform": c.extra["cvm"]["transform"],
                                  "min": c.min["w"], "rel_published": _rel(c.min["w"], pub["min"]["w"]),
                                  "rel_convex": _rel(c.min["w"], result.min["w"]),
                                  "energy_gap": c.extra["cvm"]["energy_gap"],
                                  "iterations": c.extra["cvm"]["iterations"]}
                rows.append(row)
    return rows


def _flags(row) -> list[str]:
    flags = []
    c = row.get("cvm")
    if c is not None and (c["status"] != "optimal" or abs(c["rel_convex"]) > 1e-3):
        flags.append("CVM disagrees with convex")
    for key in ("min", "max"):
        if key in row:
            if abs(row[key]["rel"]) > FLAG_W:
                flags.append(f"{key} w off")
            if abs(row[key]["x_ours"] - row[key]["x_published"]) > 5e-4:
                flags.append(f"{key} x differs")
    if abs(row["energy"]["rel"]) > FLAG_E:
        flags.append("energy off")
    if "zone" in row:
        ours = row["zone"]["ours"]
        pub = row["zone"]["published"]
        if len(ours) != 1 or any(abs(a - b) > 5e-4 for a, b in zip(ours[0], pub)):
            flags.append("zone differs")
    return flags


def thesis_markdown(rows: list[dict], command: str) -> str:
    """The rows as a Markdown table, with the command that made it."""
    out = [
        "# The thesis's published cases, reproduced",
        "",
        f"Made by `{command}`. Common data: L = 1 m, h = 0.1 m, b = 1 m, nu = 0.3, "
        "E = 2.1e11 Pa, 32 equal elements. *ours* is gaocvx's convex ground truth on the same "
        "mesh; *rel* is (ours - published) / |published|. Rows with mu = 1 use the override "
        "`beam.mu = 1.0`, which the thesis's computations used for P != 0 on supports P1, P2, P4. "
        f"Flags mark differences above {FLAG_W:.1%} (deflection), {FLAG_E:.2%} (energy), "
        "a different node for an extremum, or a different contact zone.",
        "",
        "",
        "The CVM columns are gaocvx's own CVM, computed the thesis's way (transform T1 for P1/P2, "
        "T2 for P3, T3 for P4, piecewise-linear control on the same mesh, projected Newton): "
        "its min w relative to the published value and to the convex ground truth, and its "
        "energy gap Pi_T(w_cvm) - Pi_T(w_convex) in J.",
        "",
        "| table | model | mu | min w published | min w ours | rel | x pub / ours "
        "| max w rel | energy published | energy ours | rel | zone published | zone ours "
        "| CVM | CVM rel pub | CVM rel convex | CVM energy gap | flags |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m = r["min"]
        mx = f"{r['max']['rel']:+.2%}" if "max" in r else ""
        zone_p = zone_o = ""
        if "zone" in r:
            zone_p = "[{:.3f}, {:.3f}]".format(*r["zone"]["published"])
            zone_o = ", ".join(f"[{a:.3f}, {b:.3f}]" for a, b in r["zone"]["ours"])
        mu = "1" if r["mu"] else "model"
        c = r.get("cvm")
        cvm = ("| | | | " if c is None else
               f"| {c['transform']} {c['status']} | {c['rel_published']:+.2%} | "
               f"{c['rel_convex']:+.1e} | {c['energy_gap']:.2g} ")
        out.append(
            f"| {r['table']} | {r['model']} | {mu} | {m['published']:.4g} | {m['ours']:.5g} | "
            f"{m['rel']:+.2%} | {m['x_published']:.3f} / {m['x_ours']:.3f} | {mx} | "
            f"{r['energy']['published']:.4g} | {r['energy']['ours']:.5g} | "
            f"{r['energy']['rel']:+.2%} | {zone_p} | {zone_o} {cvm}| {'; '.join(_flags(r))} |")
    return "\n".join(out) + "\n"
