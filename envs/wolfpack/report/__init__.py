"""The report: the tables and figures of every kind of result, each made from its JSON alone, so
that ``training/results_report.py`` regenerates RESULTS.md and its pictures from the committed
results, and each training script writes the same ones beside its own results."""
