"""A self-contained static HTML report of a run folder (`sgpipe report RUN_DIR`): collect.py
reads the run folder, plots.py draws the charts, page.py renders the jinja2 templates,
build.py writes the report folder atomically, command.py is the click command."""
