; Clutter: a PR2 moves sticks between tables (thesis ch. 2). Native tmpc dialect: geometric
; predicates carry their meaning inline; `holding` re-parents the stick under the gripper.
(define (domain clutter)
  (:requirements :strips :typing :tmpc)
  (:types stick surface manipulator - object)
  (:include "tmpc/geometry")
  (:predicates
    (on-surface ?x - stick ?s - surface)
    (arm-empty ?m - manipulator)
    (holding ?m - manipulator ?x - stick :kinematic (link ?m ?x))
    ; the gripper's tool frame is close enough to grasp the stick
    (at ?m - manipulator ?x - stick :semantics (near ?m ?x 0.05))
    ; the stick rests on the table's support region: upright within 0.07 rad, its bottom 0-8 mm
    ; above the table top (what `tmpc validate` accepts as resting, W830)
    (placed ?x - stick ?s - surface :semantics (rests-on ?x ?s 0.07)))
  (:action pickup
    :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (on-surface ?x ?s) (arm-empty ?m) (at ?m ?x))
    :effect (and (holding ?m ?x) (not (on-surface ?x ?s)) (not (arm-empty ?m))))
  (:action putdown
    :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (holding ?m ?x) (placed ?x ?s))
    :effect (and (arm-empty ?m) (on-surface ?x ?s) (not (holding ?m ?x)))))
