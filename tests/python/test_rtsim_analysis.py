"""reports/python/rtsim_analysis.py on real outputs of the rtsim under test (RTSIM_BINARY):
a stats.json, a timeline and a campaign database load into DataFrames whose numbers
are the files' own (the accounting adds up in the timeline frame too)."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.environ["RTSIM_SOURCE_DIR"], "reports", "python"))
import rtsim_analysis as ra  # noqa: E402

RTSIM = os.environ["RTSIM_BINARY"]


class RtsimAnalysis(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="rtsim_analysis_")
        cls.out = os.path.join(cls.dir, "run")
        cls.timeline = os.path.join(cls.dir, "timeline.json")
        subprocess.run([RTSIM, "simulate", "--scene", "cornell", "--res", "16x16", "--fidelity", "cycle",
                        "--config", "mobile", "--out-dir", cls.out, "--timeline", cls.timeline],
                       check=True, stdout=subprocess.DEVNULL)
        campaign = os.path.join(cls.dir, "c.toml")
        with open(campaign, "w") as f:
            f.write('[campaign]\nname = "py"\n[sweep]\nscene = "cornell"\nbuilder = ["sah", "median"]\n'
                    'resolution = "8x8"\nset.l2.size_bytes = [262144, 1048576]\n')
        subprocess.run([RTSIM, "campaign", "run", campaign, "-j", "2", "--no-tree-cache", "--no-results-cache"],
                       check=True, stdout=subprocess.DEVNULL)
        cls.database = os.path.join(cls.dir, "rtsim-campaigns", "py", "results.sqlite")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir)

    def test_stats_are_the_files_numbers_with_units(self):
        stats = ra.load_stats(os.path.join(self.out, "stats.json"))
        with open(os.path.join(self.out, "stats.json")) as f:
            raw = json.load(f)
        self.assertEqual(stats.loc["time.cycles", "value"], raw["time"]["cycles"]["value"])
        self.assertEqual(stats.loc["dram.bytes_per_ray", "unit"], "bytes/ray")
        self.assertEqual(stats.loc["core0.trv0.busy_cycles", "unit"], "cycles")
        self.assertTrue(stats.loc["core0.trv0.busy_cycles", "description"])
        self.assertEqual(len(stats), len(ra.flatten_stats(raw)))

    def test_a_campaign_is_one_row_per_run_with_its_stats(self):
        runs = ra.load_campaign(self.database)
        self.assertEqual(len(runs), 4)
        self.assertEqual(sorted(set(runs["builder"])), ["median", "sah"])
        self.assertEqual(sorted(set(runs["set.l2.size_bytes"])), [262144, 1048576])
        self.assertEqual(runs.attrs["units"]["dram.bytes_per_ray"], "bytes/ray")
        # The same number as the row's stats_json holds.
        import sqlite3
        with sqlite3.connect(self.database) as db:
            key, stats_json = db.execute("SELECT job_key, stats_json FROM runs LIMIT 1").fetchone()
        expected = ra.flatten_stats(json.loads(stats_json))["ops.per_ray"][0]
        self.assertEqual(runs.set_index("job_key").loc[key, "ops.per_ray"], expected)
        table = runs.pivot_table(index="builder", columns="set.l2.size_bytes", values="dram.bytes_per_ray")
        self.assertEqual(table.shape, (2, 2))

    def test_a_timelines_unit_spans_are_the_cycle_accounting(self):
        spans = ra.load_timeline(self.timeline)
        self.assertEqual(spans.attrs["level"], "cycle")
        self.assertGreater(len(spans), 100)
        stats = ra.load_stats(os.path.join(self.out, "stats.json"))["value"]
        split = ra.cycle_split(spans)
        self.assertIn("core0.trv0", split.index)
        for track, row in split.iterrows():
            for state, cycles in row.items():
                key = "%s.%s_cycles" % (track, state)
                if key not in stats:  # a state this kind of unit has not (the table is filled with 0)
                    self.assertEqual(cycles, 0.0, key)
                    continue
                # Spans are exact in picoseconds; the stat is rounded to whole cycles.
                self.assertLess(abs(cycles - stats[key]), 1.0, key)
        self.assertTrue({"ACT", "RD"} <= set(spans["name"]))


if __name__ == "__main__":
    unittest.main()
