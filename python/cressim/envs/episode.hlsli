// The end of a task step, shared by the task passes (after their buffer declarations: pc with
// max_steps and reset_all, terminated, truncated, episode_length, finished_length). Counts the
// episode's steps and ends it when `ended` (success or failure: terminated) or at pc.max_steps
// (truncated); with pc.reset_all every env starts afresh and no episode is counted. Returns
// whether the env starts a new episode.
bool end_step(uint env, bool ended) {
  const uint steps = episode_length[env] + 1;
  const bool counted = pc.reset_all == 0, over = steps >= pc.max_steps;
  const bool done = !counted || ended || over;
  terminated[env] = counted && ended ? 1 : 0;
  truncated[env] = counted && over && !ended ? 1 : 0;
  finished_length[env] = done && counted ? float(steps) : 0.0;
  episode_length[env] = done ? 0 : steps;
  return done;
}
