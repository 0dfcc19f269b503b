"""Speed and memory targets, printed as ratios against baselines measured in the same run."""
