"""The soak (issue 31, benchmarks/soak.py): a deploy profile run for hours under a scripted day.

day: what happens when (pure data); rig: the profile brought up with its remote teacher, its page, its
small disk; watch: what the loop did, taken from the bus as it comes; sample: each minute's figures;
stranger: a stranger's burst (run as a process of its own); records: the recordings checked afterwards;
figures: growth, quarters and the summary.
"""
