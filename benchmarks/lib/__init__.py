"""What benchmarks (and some tests) share that is not a benchmark: task data, the UDP echo floor."""
