"""The benchmark: it runs episodes and computes every number the results and plots show.

- runner: one episode (a task, a controller, a seed); execution: many of them in process, on
  a process pool or on Ray; experiments/: their TOML definitions; plugins: users'
  controllers; results: the SQLite database; stats, report: the tables; plots, ekf_plot: the
  numbers behind the report's plots and the EKF plot, drawn by dcmppi.render; snapshot: one
  step of every controller (the paper's figures); timing, peer: speed.

May import dcmppi.control, dcmppi.tasks and dcmppi.render. Nothing in dcmppi.control,
dcmppi.tasks or dcmppi.render imports it (tests/test_architecture.py checks this).
"""
