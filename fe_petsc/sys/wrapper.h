#include <petscdmplex.h>
#include <petscksp.h>
#include <petscsf.h>
#include <petscsection.h>
#include <petscpartitioner.h>
