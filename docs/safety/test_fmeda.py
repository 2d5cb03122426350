"""Tests of fmeda.py: the real FMEDA parses and supports PL b; every kind
of malformed row is refused; the PL table and bands are ISO 13849-1's.
Run: python3 -m unittest discover -s docs/safety -p 'test_*.py'"""
import os
import unittest

import fmeda

HERE = os.path.dirname(os.path.abspath(__file__))
HEADER = ",".join(fmeda.COLUMNS)
GOOD = ("X-1,part,2,CH1,mode a,0.6,effect,SR-11,3,0.6,ISO 13849-1 Table E.1,1141,"
        "DEFAULT: assumed 100 FIT dangerous (test),yes\n"
        "X-2,part,2,CH1,mode b,0.4,effect,none,-,0,none,1141,DEFAULT: assumed 100 FIT dangerous (test),yes\n")


def table(body):
    return HEADER + "\n" + body


class RealFmeda(unittest.TestCase):
    def test_the_package_fmeda_supports_pl_b(self):
        with open(os.path.join(HERE, "FMEDA.csv"), encoding="utf-8") as f:
            rows = fmeda.parse_fmeda(f.read())
        with open(os.path.join(HERE, "CCF.csv"), encoding="utf-8") as f:
            ccf = fmeda.parse_ccf(f.read())
        _, channels = fmeda.analyse(rows)
        c = channels["CH1"]
        pl, _ = fmeda.performance_level("B", c["mttfd"], c["dc_avg"], sum(p for _, _, p in ccf))
        self.assertEqual(pl, "b")
        self.assertLess(sum(p for _, _, p in ccf), 65)

    def test_a_good_table_parses_and_computes(self):
        rows = fmeda.parse_fmeda(table(GOOD))
        parts, channels = fmeda.analyse(rows)
        self.assertAlmostEqual(parts[("CH1", "part")]["dc"], 0.36)
        self.assertAlmostEqual(channels["CH1"]["mttfd"], 1141 / 2)
        self.assertAlmostEqual(channels["CH1"]["dc_avg"], 0.36)


class Malformed(unittest.TestCase):
    def refused(self, text, fragment):
        with self.assertRaises(fmeda.Malformed) as e:
            fmeda.parse_fmeda(text)
        self.assertTrue(any(fragment in p for p in e.exception.problems), e.exception.problems)

    def test_wrong_header(self):
        self.refused("id,part\n" + GOOD, "header")

    def test_missing_cell(self):
        self.refused(table(GOOD.replace(",effect,SR-11", ",SR-11", 1)), "cells, expected")

    def test_not_a_number(self):
        self.refused(table(GOOD.replace("0.6,ISO", "high,ISO", 1)), "dc is not a number")

    def test_dc_above_99_percent(self):
        self.refused(table(GOOD.replace("0.6,ISO", "1.0,ISO", 1)), "dc must be in")

    def test_dc_without_a_diagnostic(self):
        self.refused(table(GOOD.replace("-,0,none", "5,0.9,none", 1)), "without a diagnostic")

    def test_dc_without_a_source(self):
        self.refused(table(GOOD.replace("0.6,ISO 13849-1 Table E.1", "0.6,none", 1)), "without a source")

    def test_fractions_not_adding_to_one(self):
        self.refused(table(GOOD.replace(",0.4,", ",0.3,", 1)), "add up to")

    def test_unmarked_default(self):
        self.refused(table(GOOD.replace("DEFAULT: assumed", "assumed")), "must be marked")

    def test_mttfd_disagreeing_with_its_fit(self):
        self.refused(table(GOOD.replace(",1141,", ",2000,")), "disagrees with its source")

    def test_mttfd_differing_between_modes(self):
        self.refused(table(GOOD.replace(",1141,DEFAULT: assumed 100", ",571,DEFAULT: assumed 200", 1)), "differs between")

    def test_duplicate_id(self):
        self.refused(table(GOOD.replace("X-2", "X-1")), "duplicate id")

    def test_empty_cell(self):
        self.refused(table(GOOD.replace(",effect,", ",,", 1)), "empty effect")

    def test_ccf_points_above_maximum(self):
        with self.assertRaises(fmeda.Malformed):
            fmeda.parse_ccf("measure,max_points,points,justification\nx,5,6,why\ny,95,0,why\n")


class Iso13849Tables(unittest.TestCase):
    def test_bands(self):
        self.assertEqual(fmeda.mttfd_band(2.9), "below 3 years (not acceptable)")
        self.assertEqual(fmeda.mttfd_band(9.9), "low")
        self.assertEqual(fmeda.mttfd_band(10), "medium")
        self.assertEqual(fmeda.mttfd_band(30), "high")
        self.assertEqual(fmeda.dc_band(0.59), "none")
        self.assertEqual(fmeda.dc_band(0.9), "medium")
        self.assertEqual(fmeda.dc_band(0.99), "high")

    def test_category_b_is_capped_at_pl_b(self):
        self.assertEqual(fmeda.performance_level("B", 500, 0.99, 100)[0], "b")
        self.assertEqual(fmeda.performance_level("B", 5, 0.0, 0)[0], "a")

    def test_category_3_needs_the_ccf_score(self):
        self.assertIsNone(fmeda.performance_level("3", 50, 0.95, 60)[0])
        self.assertEqual(fmeda.performance_level("3", 50, 0.95, 65)[0], "d")
        self.assertEqual(fmeda.performance_level("4", 50, 0.99, 80)[0], "e")


if __name__ == "__main__":
    unittest.main()
