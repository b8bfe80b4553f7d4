; Repair experiment 1 (thesis §3.6): the Pick controller's real precondition is hidden in
; exp1.truth; this model says the gripper only has to be within 0.5 m of the cube.
(define (domain pick)
  (:requirements :strips :typing :tmpc)
  (:types gripper cube)
  (:include "tmpc/templates")
  (:predicates
    (empty ?g - gripper)
    (holding ?g - gripper ?c - cube :kinematic (link ?g ?c))
    ; where the controller can grasp the cube from
    (graspable ?c - cube ?g - gripper :semantics (dist ?c ?g 0.5)))
  (:action pick
    :parameters (?g - gripper ?c - cube)
    :precondition (and (graspable ?c ?g))
    :effect (and (holding ?g ?c) (not (empty ?g)))))
