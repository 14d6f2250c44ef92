"""Learned foot-contact estimator (Yu, Park & Lee 2021, "movingcam", sections 4 and 6).

    probabilities = FootContactEstimator().estimate(points2d, confidence, fps)  # (T, 2) right, left
"""
