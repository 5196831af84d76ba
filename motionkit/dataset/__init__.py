"""The MCAP motion dataset format: writer, reader, validation, AMP features.

from motionkit.dataset import read, write
trajectory = read("walk.mcap")          # a Trajectory of float32 arrays
write("copy.mcap", trajectory, robot)   # atomic; /motion, /tf, metadata, URDF attachment
"""

from motionkit.dataset.amp import AmpPairs, amp_features, amp_pairs, feature_names, resample
from motionkit.dataset.clip import corner_names, encode, read, read_metadata, write
from motionkit.dataset.collection import MotionDataset
from motionkit.dataset.trajectory import Metadata, Source, Trajectory

__all__ = [
    "AmpPairs",
    "Metadata",
    "MotionDataset",
    "Source",
    "Trajectory",
    "amp_features",
    "amp_pairs",
    "corner_names",
    "encode",
    "feature_names",
    "read",
    "read_metadata",
    "resample",
    "write",
]
