"""Reports of results databases: tables, CSV, plots, the outcome rule.

    report.py        paper-style tables, diagnostics, the field's metrics, CSV
    html.py          report.html: the tables sortable, plots inline, failures linked to viewers
    plots.py         the numbers behind the report's plots (dcmppi.render draws them)
    ekf_plot.py      the obstacle filters' errors over one crowd episode
    outcomes.py      `dcmppi outcomes`: two codes' outcomes on the same episodes

The top layer of dcmppi.bench but timing: may import every other part of it and dcmppi.render.
"""
