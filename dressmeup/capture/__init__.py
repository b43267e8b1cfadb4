"""Capture sessions and rigs (docs/capture-format.md).

- :mod:`~dressmeup.capture.rig`: ``Camera``, ``Rig``, ``load_rig``/``save_rig``, ``ring_rig``
  (the default 7-camera ring), ``perturb_rig`` (a drifted calibration).
- :mod:`~dressmeup.capture.session`: ``open_session`` / ``validate_session`` (every problem,
  each naming its file), ``Session.load_frames``, ``write_session`` / ``write_frame``.
- :mod:`~dressmeup.capture.synthetic`: ray-cast RGBD rendering with a Kinect-like noise
  model, ``make_mannequin``, ``subject_from_sample``, ``synth_capture``, ``load_ground_truth``.
- :mod:`~dressmeup.capture.calibration`: extrinsics from ChArUco-board images.
- :mod:`~dressmeup.capture.kinect`: Azure Kinect MKV recordings through the optional pyk4a
  (untested on hardware).

Submodules import their heavy dependencies (OpenCV, open3d) inside functions.
"""
