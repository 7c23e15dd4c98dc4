"""The simulated world: what avhear runs on when there is no robot, and the ground truth it is scored against.

- :mod:`sim.synthetic`: the feature-level sequences of the paper's section 7.1 (3D points and ITDs);
  :mod:`app.eval.synthetic` runs Algorithm 1 and 2 on them.
- :mod:`sim.scenario`: the scenarios of section 7.3 (people, sound events, rooms); :mod:`sim.render` draws the
  stereo images (people's bodies from :mod:`sim.person_body`; :mod:`sim.body_truth` says where a motion-guided
  method should find them); :mod:`sim.roomsim` makes the room acoustics and reads the real speech and noise;
  :mod:`sim.audio` renders the microphones' signals of a scenario.
- :mod:`sim.calibration`: a calibration session of section 5.3 with known truth.

It uses the method (:mod:`avcore`); the method never imports it. Real third-party data (faces, speech, noise) is
read from :func:`sim.roomsim.resolve_data_dir`: the ``AVHEAR_DATA`` environment variable, or ``../shared/data`` relative
to the current folder (the repository's root, where the README's commands run).
"""
