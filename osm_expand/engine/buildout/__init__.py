"""The build-out: land use, lots, building footprints, the economy, and the town's own calibration of them."""
