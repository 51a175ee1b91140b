// The distance family's passes (particle_solve.hlsli); its constraint is in particle_distance.hlsli.
#include "particle_constraint.hlsli"
#include "particle_distance.hlsli"
#define evaluate evaluate_distance
#include "particle_solve.hlsli"
