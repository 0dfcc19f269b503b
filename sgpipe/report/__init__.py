"""A self-contained static HTML report of a run folder."""
