"""Learned tactile models (ForceLearn, StirLearn): per-tick features from TactileStates, the
recording file format, model files that carry their feature spec, and training."""
