; A Panda on a bench moves cubes into a tray: small and fast, for tests and tutorials.
(define (domain tabletop)
  (:requirements :strips :typing :tmpc)
  (:types cube surface gripper)
  (:include "tmpc/geometry")
  (:predicates
    (on ?c - cube ?s - surface)
    (free ?g - gripper)
    (holding ?g - gripper ?c - cube :kinematic (link ?g ?c))
    ; the tool centre point is at the cube, pointing down
    (reach ?g - gripper ?c - cube
      :semantics (and (near ?g ?c 0.02) (aligned (z-axis ?g) (vec3 0 0 -1) 0.2)))
    ; the tool centre point is over the surface, at most 15 cm above its support region
    (over ?g - gripper ?s - surface :semantics (over-support ?g ?s 0.15))
    ; the cube rests on the surface's support region: upright within 0.07 rad, its bottom 0-8 mm
    ; above the region's floor (what `tmpc validate` accepts as resting, W830)
    (resting ?c - cube ?s - surface :semantics (rests-on ?c ?s 0.07)))
  (:action pick
    :parameters (?g - gripper ?c - cube ?s - surface)
    :precondition (and (free ?g) (on ?c ?s) (reach ?g ?c))
    :effect (and (holding ?g ?c) (not (free ?g)) (not (on ?c ?s))))
  (:action place
    :parameters (?g - gripper ?c - cube ?s - surface)
    :precondition (and (holding ?g ?c) (over ?g ?s) (resting ?c ?s))
    :effect (and (on ?c ?s) (free ?g) (not (holding ?g ?c)))))
