-- sweep store, schema 2: lease a campaign's jobs in id order instead of insertion order.
--
-- A job id is a hash of its parameters, so id order is a fixed pseudo-random permutation of the plan.
-- Timings drift with the machine's load; in plan order (L* outer, W* inner) a burst of load became a
-- stripe in the (L*, W*) plane that looked like physics. In id order it is noise spread over the plane,
-- and the order is still the same on every run and every resume.
DROP INDEX jobs_state_created;
CREATE INDEX jobs_state_created_id ON jobs (state, created_at, id);
