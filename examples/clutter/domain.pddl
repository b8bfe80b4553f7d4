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
    ; the stick stands over the table's support region, upright and low enough to count as
    ; put down (the collision check keeps it out of the table)
    (placed ?x - stick ?s - surface :semantics (and (on-support ?x ?s) (upright ?x 0.2))))
  (:action pickup
    :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (on-surface ?x ?s) (arm-empty ?m) (at ?m ?x))
    :effect (and (holding ?m ?x) (not (on-surface ?x ?s)) (not (arm-empty ?m))))
  (:action putdown
    :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (holding ?m ?x) (placed ?x ?s))
    :effect (and (arm-empty ?m) (on-surface ?x ?s) (not (holding ?m ?x)))))
