; Stack cubes with a Panda, the goal written with the geometric predicate itself (docs/tutorial.md).
(define (domain tower)
  (:requirements :strips :typing :tmpc)
  (:types surface gripper - object cube - surface)
  (:include "tmpc/geometry")
  (:predicates
    (free ?g - gripper)
    (holding ?g - gripper ?c - cube :kinematic (link ?g ?c))
    ; the tool centre point is at the cube, pointing down
    (reach ?g - gripper ?c - cube
      :semantics (and (near ?g ?c 0.02) (aligned (z-axis ?g) (vec3 0 0 -1) 0.2)))
    ; the cube rests on the support region of ?s (a cube's is its top face)
    (on ?c - cube ?s - surface :semantics (rests-on ?c ?s 0.07)))
  (:action pick
    :parameters (?g - gripper ?c - cube)
    :precondition (and (free ?g) (reach ?g ?c))
    :effect (and (holding ?g ?c) (not (free ?g))))
  ; put the cube down so that it rests on ?s: the goal's `on` atoms are achieved here
  (:action place
    :parameters (?g - gripper ?c - cube ?s - surface)
    :precondition (and (holding ?g ?c) (on ?c ?s))
    :effect (and (free ?g) (not (holding ?g ?c)))))
