// The implicit integrator's colouring (vbd.h sweeps one colour at a time, each in parallel): greedy
// in vertex order over the springs, no two vertices of a colour sharing one; a seam partner takes
// its representative's place, so only representatives are coloured. Fills m.color_offset and
// m.color_vertices from m.adj_offset and m.adj_other (build_adjacency calls it).
#pragma once

#include "sim/model.h"

namespace raycloth {

void color_vertices(ClothModel& m);

}  // namespace raycloth
