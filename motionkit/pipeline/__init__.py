"""`motionkit pipeline`: every stage from raw data to a trained policy, cached by input hash."""
