"""The year's traffic: neighbouring cities, trade routes, trips inside the town, widths and status."""
