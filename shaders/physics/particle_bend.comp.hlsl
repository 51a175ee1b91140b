// The bend family's passes (particle_solve.hlsli); its constraint is in particle_bend.hlsli.
#define CRESSIM_RECORD_ZW  // the segment length
#include "particle_constraint.hlsli"
#include "particle_bend.hlsli"
#define evaluate evaluate_bend
#include "particle_solve.hlsli"
