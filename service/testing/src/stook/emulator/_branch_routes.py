"""The branches listing (`GET /projects/{projectID}/branches`, filtered by `name`)."""

from __future__ import annotations

from aiohttp import web

from stook.emulator._baseline_pair import branches
from stook.emulator._json import timestamp
from stook.emulator._middleware import error_response, json_response
from stook.emulator._paging import PagingError, paginate
from stook.emulator._state import EmulatorState
from stook.emulator._world import BASE_TIME


def add_branch_routes(app: web.Application, state: EmulatorState, prefix: str) -> None:
    async def list_branches(request: web.Request) -> web.Response:
        ds = state.dataset
        if request.match_info["project_id"] != str(ds.project_id):
            return error_response(404, f"project {request.match_info['project_id']} not found")
        name = request.query.get("name")
        items = [
            {
                "branchID": str(branch_id),
                "name": branch_name,
                "projectID": str(ds.project_id),
                "branchType": "MAIN" if branch_name == "main" else "CHANGE_REQUEST",
                "creationTimestamp": timestamp(BASE_TIME),
                "userID": str(ds.user_id),
                "orgID": ds.org_id,
            }
            for branch_id, branch_name in branches(ds)
            if name is None or branch_name == name
        ]
        try:
            page = paginate(
                items,
                request.query,
                f"branches:{name}",
                default=state.config.default_page_size,
                maximum=state.config.max_page_size,
            )
        except PagingError as exc:
            return error_response(400, str(exc))
        return json_response(
            {"branches": list(page.items), "nextPageToken": page.next_token, "total": page.total}
        )

    app.router.add_get(f"{prefix}/branches", list_branches, name="list_branches")


__all__ = ["add_branch_routes"]
