-- The [[tune]] searches of a campaign as its submitter expanded them (one JSON document each,
-- opaque here): whoever drives or reports them reads them back instead of the plan, whose
-- relative paths only its submitter's folder resolves.
CREATE TABLE searches (
    campaign_id TEXT NOT NULL REFERENCES campaigns (id),
    search      TEXT NOT NULL CHECK (json_valid(search)),
    PRIMARY KEY (campaign_id, search)
) STRICT;
