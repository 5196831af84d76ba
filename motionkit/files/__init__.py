"""Files in and out: checked readers of inputs (`inputs`), output folders with their manifest
(`outputs`) and the content and code hashes that say an output is up to date (`digests`)."""
