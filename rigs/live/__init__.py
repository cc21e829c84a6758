"""Experiments other than the headline demo's ball seeking (services/demo), brought up live by the
supervisor, every box a process, for the tests and benchmarks: mirroring.py (section V.A), hierarchy.py
(deploy/hierarchy.toml's two levels), page.py (ball seeking with its page); fits.py says when a live
learner's fits have caught up."""
