#!/usr/bin/env python3
"""FMEDA of the PAROL6 control channel: DC per part, DC_avg, MTTFd per
channel, common-cause score and the performance level they support, by the
simplified method of ISO 13849-1 (its MTTFd and DC bands, and the
category / DC_avg / MTTFd -> PL relation of its bar chart, tabulated in
Annex K).

Usage: python3 docs/safety/fmeda.py [FMEDA.csv] [CCF.csv] [--category B]

Rows of FMEDA.csv are the dangerous failure modes of a part: `mode_fraction`
apportions the part's dangerous failure rate among its modes (they must add
up to 1), `dc` is the diagnostic coverage of the mode (0..0.99, with its
source), `mttfd_years` the part's MTTFd (one value per part, with its source;
`mttfd_default` = yes marks an assumed value, whose source must start with
DEFAULT). A source that states "N FIT" or "B10d N operations ... at M
operations a year" is recomputed and must match the MTTFd given.

The category is the architecture's, not a result: one channel, no test
equipment, so category B (docs/safety/ARCHITECTURE.md). `--category` shows
what the same figures would support in another category; it does not make
the hardware meet that category's structural requirements.

Exits 1 with every problem listed if a row is malformed. Python standard
library only.
"""
import csv
import re
import sys

COLUMNS = ["id", "part", "qty", "channel", "failure_mode", "mode_fraction", "effect", "diagnostic",
           "detection_time_ms", "dc", "dc_source", "mttfd_years", "mttfd_source", "mttfd_default"]
CCF_COLUMNS = ["measure", "max_points", "points", "justification"]
HOURS_PER_YEAR = 8760.0


class Malformed(Exception):
    """Raised with every problem found in the input."""

    def __init__(self, problems):
        super().__init__("\n".join(problems))
        self.problems = problems


def _num(text, what, problems, row_id):
    try:
        return float(text)
    except ValueError:
        problems.append(f"{row_id}: {what} is not a number: {text!r}")
        return None


def parse_fmeda(text):
    """Rows of FMEDA.csv as dicts with numbers converted; raises Malformed."""
    problems = []
    reader = csv.reader(text.splitlines())
    header = next(reader, None)
    if header != COLUMNS:
        raise Malformed([f"header must be {','.join(COLUMNS)}, got {header}"])
    rows, ids = [], set()
    for n, cells in enumerate(reader, start=2):
        if not cells or all(not c.strip() for c in cells):
            continue
        row_id = f"line {n}"
        if len(cells) != len(COLUMNS):
            problems.append(f"{row_id}: {len(cells)} cells, expected {len(COLUMNS)}")
            continue
        r = dict(zip(COLUMNS, (c.strip() for c in cells)))
        row_id = f"line {n} ({r['id']})"
        for c in COLUMNS:
            if not r[c]:
                problems.append(f"{row_id}: empty {c}")
        if r["id"] in ids:
            problems.append(f"{row_id}: duplicate id")
        ids.add(r["id"])
        qty = _num(r["qty"], "qty", problems, row_id)
        if qty is not None and (qty < 1 or qty != int(qty)):
            problems.append(f"{row_id}: qty must be a positive integer")
        frac = _num(r["mode_fraction"], "mode_fraction", problems, row_id)
        if frac is not None and not 0 < frac <= 1:
            problems.append(f"{row_id}: mode_fraction must be in (0, 1]")
        dc = _num(r["dc"], "dc", problems, row_id)
        if dc is not None and not 0 <= dc <= 0.99:
            problems.append(f"{row_id}: dc must be in [0, 0.99] (ISO 13849-1 caps DC at 99 %)")
        if dc and r["diagnostic"].startswith("none"):
            problems.append(f"{row_id}: dc {dc} claimed without a diagnostic")
        if dc and r["detection_time_ms"] == "-":
            problems.append(f"{row_id}: dc {dc} claimed without a detection time")
        if r["detection_time_ms"] != "-":
            t = _num(r["detection_time_ms"], "detection_time_ms", problems, row_id)
            if t is not None and t <= 0:
                problems.append(f"{row_id}: detection_time_ms must be positive")
        if dc and r["dc_source"] == "none":
            problems.append(f"{row_id}: dc {dc} claimed without a source")
        mttfd = _num(r["mttfd_years"], "mttfd_years", problems, row_id)
        if mttfd is not None and mttfd <= 0:
            problems.append(f"{row_id}: mttfd_years must be positive")
        if r["mttfd_default"] not in ("yes", "no"):
            problems.append(f"{row_id}: mttfd_default must be yes or no")
        if r["mttfd_default"] == "yes" and not r["mttfd_source"].startswith("DEFAULT"):
            problems.append(f"{row_id}: an assumed MTTFd must be marked: source starting with DEFAULT")
        if r["mttfd_default"] == "no" and r["mttfd_source"].startswith("DEFAULT"):
            problems.append(f"{row_id}: source says DEFAULT but mttfd_default is no")
        if mttfd is not None:
            implied = implied_mttfd(r["mttfd_source"])
            if implied is not None and abs(implied - mttfd) > 0.01 * implied + 0.5:
                problems.append(f"{row_id}: mttfd_years {mttfd} disagrees with its source ({implied:.0f} years)")
        if None in (qty, frac, dc, mttfd):
            continue
        r.update(qty=int(qty), mode_fraction=frac, dc=dc, mttfd_years=mttfd)
        rows.append(r)
    parts = {}
    for r in rows:
        parts.setdefault((r["channel"], r["part"]), []).append(r)
    for (ch, part), modes in parts.items():
        total = sum(m["mode_fraction"] for m in modes)
        if abs(total - 1.0) > 1e-6:
            problems.append(f"{part} ({ch}): mode fractions add up to {total:.3f}, not 1")
        for key in ("qty", "mttfd_years", "mttfd_source"):
            if len({m[key] for m in modes}) != 1:
                problems.append(f"{part} ({ch}): {key} differs between its modes")
    if not rows and not problems:
        problems.append("no rows")
    if problems:
        raise Malformed(problems)
    return rows


def implied_mttfd(source):
    """MTTFd in years implied by a source text, or None if it states none."""
    m = re.search(r"B10d ([0-9]+) operations.*? at ([0-9]+) operations a year", source)
    if m:
        return float(m.group(1)) / (0.1 * float(m.group(2)))
    m = re.search(r"assumed ([0-9.]+) FIT dangerous", source)
    if m:
        return 1e9 / (float(m.group(1)) * HOURS_PER_YEAR)
    return None


def parse_ccf(text):
    problems = []
    reader = csv.reader(text.splitlines())
    header = next(reader, None)
    if header != CCF_COLUMNS:
        raise Malformed([f"CCF header must be {','.join(CCF_COLUMNS)}, got {header}"])
    out = []
    for n, cells in enumerate(reader, start=2):
        if not cells:
            continue
        if len(cells) != len(CCF_COLUMNS):
            problems.append(f"CCF line {n}: {len(cells)} cells, expected {len(CCF_COLUMNS)}")
            continue
        m, mx, pts, why = (c.strip() for c in cells)
        try:
            mx, pts = int(mx), int(pts)
        except ValueError:
            problems.append(f"CCF line {n}: points must be integers")
            continue
        if not 0 <= pts <= mx:
            problems.append(f"CCF line {n}: {pts} points outside 0..{mx}")
        if not why:
            problems.append(f"CCF line {n}: no justification")
        out.append((m, mx, pts))
    if out and sum(mx for _, mx, _ in out) != 100:
        problems.append(f"CCF: maximum points add up to {sum(mx for _, mx, _ in out)}, not 100 (ISO 13849-1 Annex F)")
    if problems:
        raise Malformed(problems)
    return out


def mttfd_band(years):
    """ISO 13849-1 MTTFd bands: low 3..10, medium 10..30, high 30..100 years."""
    if years < 3:
        return "below 3 years (not acceptable)"
    if years < 10:
        return "low"
    if years < 30:
        return "medium"
    return "high"


def dc_band(dc):
    """ISO 13849-1 DC bands: none < 60 %, low 60..90, medium 90..99, high >= 99."""
    if dc < 0.60:
        return "none"
    if dc < 0.90:
        return "low"
    if dc < 0.99:
        return "medium"
    return "high"


# ISO 13849-1's simplified method (Annex K): (category, DC_avg band) -> PL per MTTFd band.
PL_TABLE = {
    ("B", "none"): {"low": "a", "medium": "b"},
    ("1", "none"): {"high": "c"},
    ("2", "low"): {"low": "a", "medium": "b", "high": "c"},
    ("2", "medium"): {"low": "b", "medium": "c", "high": "d"},
    ("3", "low"): {"low": "b", "medium": "c", "high": "d"},
    ("3", "medium"): {"low": "c", "medium": "d", "high": "d"},
    ("4", "high"): {"high": "e"},
}
# Category B allows MTTFd low to medium only: a higher value counts as medium.
MTTFD_CAP = {"B": "medium", "1": "high", "2": "high", "3": "high", "4": "high"}


def performance_level(category, mttfd_years, dc_avg, ccf_points):
    """(PL or None, reason) by the simplified method."""
    band = mttfd_band(mttfd_years)
    if band.startswith("below"):
        return None, f"MTTFd {mttfd_years:.1f} years is below 3 years"
    if band == "high" and MTTFD_CAP[category] == "medium":
        band = "medium"
    dcb = dc_band(dc_avg)
    # Categories B and 1 claim no DC; 2 and 3 need at least low, 4 high.
    if category in ("B", "1"):
        dcb = "none"
    elif category in ("2", "3") and dcb == "high":
        dcb = "medium"
    if category in ("2", "3", "4") and ccf_points < 65:
        return None, f"category {category} needs a CCF score of at least 65 (have {ccf_points})"
    pl = PL_TABLE.get((category, dcb), {}).get(band)
    if pl is None:
        return None, f"category {category} is not reached with DC_avg {dcb} and MTTFd {band}"
    return pl, f"category {category}, MTTFd {band}, DC_avg {dcb}"


def analyse(rows):
    """Per part (qty, DC, MTTFd) and per channel (MTTFd, DC_avg)."""
    parts = {}
    for r in rows:
        p = parts.setdefault((r["channel"], r["part"]), {"qty": r["qty"], "mttfd": r["mttfd_years"], "dc": 0.0,
                                                         "default": r["mttfd_default"] == "yes"})
        p["dc"] += r["mode_fraction"] * r["dc"]
    channels = {}
    for (ch, _), p in parts.items():
        c = channels.setdefault(ch, {"inv": 0.0, "dc_w": 0.0})
        c["inv"] += p["qty"] / p["mttfd"]
        c["dc_w"] += p["qty"] * p["dc"] / p["mttfd"]
    out = {}
    for ch, c in channels.items():
        out[ch] = {"mttfd": 1.0 / c["inv"], "dc_avg": c["dc_w"] / c["inv"]}
    return parts, out


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    category = "B"
    if "--category" in argv:
        category = argv[argv.index("--category") + 1]
        args.remove(category)
    if category not in MTTFD_CAP:
        print(f"unknown category {category}", file=sys.stderr)
        return 2
    here = __file__.rsplit("/", 1)[0] if "/" in __file__ else "."
    fmeda_path = args[0] if args else f"{here}/FMEDA.csv"
    ccf_path = args[1] if len(args) > 1 else f"{here}/CCF.csv"
    try:
        with open(fmeda_path, encoding="utf-8") as f:
            rows = parse_fmeda(f.read())
        with open(ccf_path, encoding="utf-8") as f:
            ccf = parse_ccf(f.read())
    except Malformed as e:
        print("fmeda: malformed input:", file=sys.stderr)
        for p in e.problems:
            print(f"  {p}", file=sys.stderr)
        return 1
    parts, channels = analyse(rows)
    print(f"FMEDA: {len(rows)} failure modes of {len(parts)} parts ({fmeda_path})")
    print(f"{'part':44} {'qty':>3} {'MTTFd/y':>8} {'DC':>6}  MTTFd source")
    for (ch, part), p in sorted(parts.items()):
        print(f"{part[:44]:44} {p['qty']:>3} {p['mttfd']:>8.0f} {p['dc']:>6.1%}  {'assumed (DEFAULT)' if p['default'] else 'data'}")
    defaults = sum(1 for p in parts.values() if p["default"])
    score = sum(pts for _, _, pts in ccf)
    print(f"common-cause failure score (ISO 13849-1 Annex F): {score} of 100 (65 needed for categories 2, 3, 4)")
    for ch, c in sorted(channels.items()):
        pl, why = performance_level(category, c["mttfd"], c["dc_avg"], score)
        print(f"channel {ch}: MTTFd {c['mttfd']:.1f} years ({mttfd_band(c['mttfd'])}), DC_avg {c['dc_avg']:.1%} ({dc_band(c['dc_avg'])})")
        print(f"channel {ch}: PL supported: {pl or 'none'} ({why})")
    print(f"{defaults} of {len(parts)} parts' MTTFd are assumed defaults: the PL holds only while real data "
          "is at least as good (docs/safety/FMEDA.csv, mttfd_source)")
    if category != "B":
        print(f"(what-if: category {category} is not the architecture's; see docs/safety/ARCHITECTURE.md)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
