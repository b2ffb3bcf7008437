"""Recordings in: ROS 1 / ROS 2 bags (``rosbags``, no ROS install) and folders of images
with a CSV of angles, imported into ``rasc-dataset/1`` folders (``rasc import``).

* :mod:`rasc.recordings.config`: what the import needs (topics, joints, board,
  thresholds), from a TOML file and options;
* :mod:`rasc.recordings.bag`: reading bags, clock checks, image decoding;
* :mod:`rasc.recordings.still`: still moments of the joint readings, nearest images;
* :mod:`rasc.recordings.importer`: :func:`import_bag`, :func:`import_image_folder`;
* :mod:`rasc.recordings.synth`: bags of known content from a rendered dataset (tests,
  benchmarks, the documentation).
"""

from rasc.recordings.config import ImportConfig, JointSource, load_config, merged
from rasc.recordings.importer import ImportResult, import_bag, import_image_folder

__all__ = ["ImportConfig", "JointSource", "load_config", "merged", "ImportResult",
           "import_bag", "import_image_folder"]
