"""Robot models: fetching and caching their files (`sfv models fetch --robot NAME`)."""
