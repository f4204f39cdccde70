"""rtsim's results as pandas DataFrames: a campaign database, a stats.json and a timeline.

    import sys; sys.path.insert(0, "reports/python")
    import rtsim_analysis as ra
    runs = ra.load_campaign("campaigns/rtsim-campaigns/example/results.sqlite")
    runs.pivot_table(index="builder", columns="preset", values="dram.bytes_per_ray")
    spans = ra.load_timeline("run.json")
    spans.groupby(["track", "name"]).cycles.sum()

Every statistic keeps its dotted name (as docs/stats.md lists them) and its unit:
load_stats gives one row per statistic with its unit and description; load_campaign
one row per run, a column per statistic, the units in runs.attrs["units"]. Needs
Debian's python3-pandas (scripts/install-deps.sh installs it).
"""
import json
import sqlite3

import pandas as pd

__all__ = ["flatten_stats", "load_stats", "load_campaign", "load_timeline", "cycle_split"]


def flatten_stats(document, prefix=""):
    """A stats.json document as {dotted key: (value, unit, description)}."""
    out = {}
    if isinstance(document, dict) and "value" in document and "unit" in document:
        out[prefix] = (document["value"], document["unit"], document.get("description", ""))
        return out
    if isinstance(document, dict):
        for key, value in document.items():
            out.update(flatten_stats(value, prefix + "." + key if prefix else key))
    return out


def load_stats(path):
    """One run's stats.json: a DataFrame indexed by dotted key, columns value, unit, description."""
    with open(path) as f:
        flat = flatten_stats(json.load(f))
    frame = pd.DataFrame([(k, v, u, d) for k, (v, u, d) in sorted(flat.items())],
                         columns=["key", "value", "unit", "description"])
    return frame.set_index("key")


# The store's identity and axis columns (docs/campaigns.md, "The results store").
_IDENTITY = ["campaign", "job_key", "label", "group_name", "status", "error", "git_revision", "host_seconds",
             "finished_at", "scene", "builder", "camera", "preset", "fidelity", "seed"]


def load_campaign(database, campaign=None, stats=True):
    """A results database: one row per run (every campaign, or one), with its identity,
    its swept values (`set.<key>` for hardware overrides, `build.<key>` for builder
    parameters, `node_format`) and, with stats, a column per statistic by dotted key.
    The units of the statistic columns are in the frame's attrs["units"]."""
    connection = sqlite3.connect("file:%s?mode=ro" % database, uri=True)
    try:
        query = "SELECT * FROM runs" + (" WHERE campaign = ?" if campaign else "") + " ORDER BY campaign, job_key"
        cursor = connection.execute(query, (campaign,) if campaign else ())
        names = [c[0] for c in cursor.description]
        rows = [dict(zip(names, r)) for r in cursor.fetchall()]
    finally:
        connection.close()
    records, units = [], {}
    for row in rows:
        record = {k: row.get(k) for k in _IDENTITY if k in row}
        job = json.loads(row.get("job_json") or "{}")
        for key, value in job.get("set", {}).items():
            record["set." + key] = _number(value)
        for key, value in job.get("build", {}).items():
            record["build." + key] = _number(value)
        if "node_format" in job:
            record["node_format"] = job["node_format"]
        if stats and row.get("stats_json"):
            for key, (value, unit, _) in flatten_stats(json.loads(row["stats_json"])).items():
                record[key] = value
                units[key] = unit
        records.append(record)
    frame = pd.DataFrame(records)
    frame.attrs["units"] = units
    return frame


def load_timeline(path):
    """A `simulate --timeline` file: one row per span, with the group (core or
    memory) and the track it is drawn on, its name (a unit's state, a miss's byte
    kind, a DRAM command, a crossbar message), its start and length in microseconds
    and in accelerator cycles, and its args. attrs holds the run's level, cycle_ps and
    whether the cap cut it short."""
    with open(path) as f:
        document = json.load(f)
    about = document.get("otherData", {}).get("rtsim", {})
    cycle_ps = about.get("cycle_ps", 1000.0)
    groups, tracks = {}, {}
    for event in document["traceEvents"]:
        if event.get("ph") != "M":
            continue
        if event["name"] == "process_name":
            groups[event["pid"]] = event["args"]["name"]
        elif event["name"] == "thread_name":
            tracks[(event["pid"], event["tid"])] = event["args"]["name"]
    rows = []
    for event in document["traceEvents"]:
        if event.get("ph") != "X":
            continue
        # Times are multiples of 2^-20 us: each is within half a picosecond of its own.
        start_ps = round(event["ts"] * 1e6)
        dur_ps = round((event["ts"] + event["dur"]) * 1e6) - start_ps
        rows.append({"group": groups.get(event["pid"]), "track": tracks.get((event["pid"], event["tid"])),
                     "name": event["name"], "start_us": event["ts"], "dur_us": event["dur"],
                     "start_ps": start_ps, "dur_ps": dur_ps, "start_cycle": start_ps / cycle_ps,
                     "cycles": dur_ps / cycle_ps, "args": event.get("args", {})})
    frame = pd.DataFrame(rows, columns=["group", "track", "name", "start_us", "dur_us", "start_ps", "dur_ps",
                                        "start_cycle", "cycles", "args"])
    frame.attrs.update({"level": about.get("level"), "cycle_ps": cycle_ps,
                        "capped_at_cycle": about.get("capped_at_cycle"), "events": about.get("events")})
    return frame


def cycle_split(spans):
    """Each unit track's drawn states in cycles (a table of track x state): the cycle
    accounting of stats.json (<unit>.<state>_cycles) as the timeline shows it; idle,
    not drawn, is the rest of the run."""
    units = spans[spans["track"].str.match(r"^core\d+\.(trv\d+|ist\d+|shading)$", na=False)]
    return units.pivot_table(index="track", columns="name", values="cycles", aggfunc="sum", fill_value=0.0)


def _number(text):
    if not isinstance(text, str):
        return text
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text
