"""Turn-H3.6M: the miner (the rule), curation overrides and manifest, Table 3, clip export."""
