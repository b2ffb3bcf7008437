"""Stereo at any gaze: the rectification of a calibrated active head for a pair of pan-tilt
readings (:mod:`~rasc.stereo.rectify`: :func:`~rasc.stereo.rectify.rectify_head`, its
result :class:`~rasc.stereo.rectify.StereoRectification`, and
:func:`~rasc.stereo.rectify.rectify_images`)."""
