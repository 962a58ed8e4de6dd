"""The tune stage: an estimator's numeric settings searched on logs with ground truth."""
