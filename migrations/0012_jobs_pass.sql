-- sweep store, schema 12: a job's scheduling pass, leased pass by pass within one submission.
--
-- An overlap point measured in several visits (the plan key `visits`) is one job per visit, and a
-- visit only tells what another run would give if it sees another state of the machine: its
-- visits must be far apart in time. Pass = the visit (0 for the first and for every other job),
-- and jobs are leased in (created_at, pass, id) order: every point's first visit, in id order,
-- then every second visit, and so on. Existing jobs are pass 0, so their order is unchanged.
ALTER TABLE jobs ADD COLUMN pass INTEGER NOT NULL DEFAULT 0 CHECK (pass >= 0);
DROP INDEX jobs_state_created_id;
CREATE INDEX jobs_state_created_pass_id ON jobs (state, created_at, pass, id);
