"""Evaluation on data with ground truth: the scenarios of section 7.3 through the real pipeline
(:mod:`app.eval.scenarios`) and the pictures of a run (:mod:`app.eval.figure`)."""
