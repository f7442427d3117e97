"""The evaluation stage: scenarios, ground truth and the figures of quality."""
