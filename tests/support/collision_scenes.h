// The collision tests' scenes and measures (tst_collision, tst_collision_schedule): two spheres
// pushed together, a cap pressed into another structure, overlap volumes and the largest steps.
#pragma once

#include "synthetic.h"

#include <memory>
#include <string>
#include <vector>

namespace sinew::testing {

// Two spheres of radius 10 mm and `innerRadius` (each its own reference, held by the shape prior),
// `gap` between centres; with the collision force weighted `weight` (none at 0), its size_share
// and reaction as given.
std::unique_ptr<Simulation> collidingSpheres(float gap, float weight, float innerRadius = 10.0f,
                                             const std::string& integrator = "damped_verlet", double timeStep = 0.5,
                                             double sizeShare = 2.0, double reaction = 0.0);

// The overlap of structures 0 and 1 (mm^3, voxelised on a 0.5 mm grid).
double pairOverlap(Simulation& sim);

// The largest sign * x over structure m's vertices: how far its side facing +x (sign 1) or -x
// (sign -1) reaches.
double reachAlongX(Simulation& sim, Index m, float sign);

// The largest motion of any vertex in the last step (mm).
double largestStep(Simulation& sim);

// The largest per-step motion over each of `blocks` blocks of 100 steps.
std::vector<double> largestStepPerHundred(Simulation& sim, int blocks);

// Structure a's cap (x beyond 8 mm) pressed by a constant force along +x (weight 0.1 times the
// vertex's mass, as the collision's pull scales: the force "press", a stand-in for an image force
// that holds a boundary inside another structure) into structure b, which does not respond
// (collision weight 0), for `steps` steps; spheres of the given radii and centres.
std::unique_ptr<Simulation> pressedCap(float radiusA, Vec3 centreA, float radiusB, Vec3 centreB, double hold,
                                       int steps = 400);

// Structure a (radius 5 mm at 3.5 mm on x) pressed as pressedCap presses it into the middle of a
// cell of structure b: a coarse sphere of radius 30 mm (the dual of a level-1 icosphere, 80
// vertices some 12 mm apart) turned so that its cell 0 faces -x, that cell's centre at x = 8.4 mm.
// Both respond (collision weight 0.5), with the hold (0.1 mm) and the given reaction; no vertex of
// b comes near a.
std::unique_ptr<Simulation> pressedIntoCell(int steps = 400, double reaction = 0.0);

// The deepest any vertex of structure `own` lies inside structure `other` (mm; 0 when none does).
double deepestInside(Simulation& sim, Index own, Index other);

}  // namespace sinew::testing
