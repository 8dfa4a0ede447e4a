"""Looking at results: the per-push summary and checks (summary), comparison with a reference
(compare), the analytic bounds and capability maps, and the figures (plots, figures)."""
