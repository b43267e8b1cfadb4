"""Capture sessions and rigs (docs/capture-format.md).

- :mod:`~dressmeup.capture.camera`: ``Camera`` and the pose rule (``rigid_pose``: nearly
  orthonormal rotations re-orthonormalised and reported, the rest refused).
- :mod:`~dressmeup.capture.rig`: ``Rig``, ``load_rig``/``read_rig``/``save_rig``, ``ring_rig``
  (the default 7-camera ring), ``perturb_rig`` (a drifted calibration).
- :mod:`~dressmeup.capture.frame`: ``RGBDFrame`` (images + the camera that took them),
  ``frame_camera``, ``with_rig_cameras``; :mod:`~dressmeup.capture.images`: session PNGs.
- :mod:`~dressmeup.capture.session`: ``open_session`` / ``check_session`` / ``validate_session``
  (every problem, each naming its file and camera), ``Session.load_frames``,
  ``write_session`` / ``write_frame``.
- :mod:`~dressmeup.capture.importers`: TUM RGB-D, 7-Scenes, Redwood/Open3D and ARKitScenes
  folders -> sessions with one camera per frame (``import_capture``).
- :mod:`~dressmeup.capture.synthetic`: ray-cast RGBD rendering with a Kinect-like noise
  model, ``make_mannequin``, ``subject_from_sample``, ``synth_capture``, ``load_ground_truth``.
- :mod:`~dressmeup.capture.calibration`: extrinsics from ChArUco-board images.
- :mod:`~dressmeup.capture.kinect`: Azure Kinect MKV recordings through the optional pyk4a
  (untested on hardware).

Submodules import their heavy dependencies (OpenCV, open3d) inside functions.
"""
