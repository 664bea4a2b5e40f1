"""Reporting: the compare report, plots as display objects, the comb and paper reports, rendering."""
