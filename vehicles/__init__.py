"""The shipped vehicle files (*.toml), installed with vsegen as package data for `vsegen list` and
`vsegen init`."""
